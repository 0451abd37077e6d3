"""Test helper: what a state graph panel drew, measured in the browser: boxes that overlap, names cut or too small
to read, names outside the panel's visible area, and edges that run through a state that is not their end."""

from __future__ import annotations

from typing import Any

MIN_FONT_PX = 11.0

MEASURE = """([panel, minFont]) => {
  const section = document.querySelector(`section[data-panel="${panel}"]`);
  const view = section.querySelector('.graph-view').getBoundingClientRect();
  const nodes = [...section.querySelectorAll('.hcm-node')].map((g) => {
    const text = g.querySelector('text');
    return { name: g.dataset.state, box: g.querySelector('rect').getBoundingClientRect(),
             label: text.getBoundingClientRect(), shown: text.textContent,
             fontPx: parseFloat(getComputedStyle(text).fontSize) * text.getScreenCTM().a };
  });
  const problems = [];
  const inside = (a, b, slack) => a.left >= b.left - slack && a.right <= b.right + slack
    && a.top >= b.top - slack && a.bottom <= b.bottom + slack;
  nodes.forEach((a, i) => nodes.slice(i + 1).forEach((b) => {
    if (a.box.left < b.box.right && b.box.left < a.box.right && a.box.top < b.box.bottom && b.box.top < a.box.bottom)
      problems.push(`${a.name} overlaps ${b.name}`);
  }));
  for (const n of nodes) {
    if (n.shown !== n.name) problems.push(`${n.name} shown as ${n.shown}`);
    if (!inside(n.label, n.box, 0.5)) problems.push(`${n.name}: name cut by its box`);
    if (n.fontPx < minFont - 0.01) problems.push(`${n.name}: ${n.fontPx.toFixed(1)} px text, under ${minFont}`);
    if (!inside(n.box, view, 0.5)) problems.push(`${n.name}: outside the panel's visible area`);
  }
  let samples = 0;
  for (const path of section.querySelectorAll('.hcm-edge')) {
    const ctm = path.getScreenCTM(), length = path.getTotalLength();
    const others = nodes.filter((n) => n.name !== path.dataset.from && n.name !== path.dataset.to);
    for (let l = 0; l <= length; l += 2) {
      const p = new DOMPoint(path.getPointAtLength(l).x, path.getPointAtLength(l).y).matrixTransform(ctm);
      samples++;
      const hit = others.find((n) => p.x > n.box.left + 1 && p.x < n.box.right - 1 && p.y > n.box.top + 1
        && p.y < n.box.bottom - 1);
      if (hit) { problems.push(`${path.dataset.from} -> ${path.dataset.to} runs through ${hit.name}`); break; }
    }
  }
  return { states: nodes.length, edges: section.querySelectorAll('.hcm-edge').length, samples, problems,
           fontPx: Math.min(...nodes.map((n) => n.fontPx)) };
}"""


def measure_state_graph(page: Any, panel: str = "hcm") -> dict[str, Any]:
    """{states, edges, samples, problems, fontPx}: problems is empty when the graph is readable."""
    result: dict[str, Any] = page.evaluate(MEASURE, [panel, MIN_FONT_PX])
    return result
