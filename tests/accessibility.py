"""Test helper: axe-core (npm, pinned by tests/axe/package-lock.json, installed by `./run test`) run inside a page.

The engine is put into the page by the test through the DevTools protocol, never served by pitchside: the page's
Content-Security-Policy stays as strict as it is for users."""

from __future__ import annotations

from typing import Any

from tests.support import REPO

AXE = REPO / "tests" / "axe" / "node_modules" / "axe-core" / "axe.min.js"
WCAG_AA = ["wcag2a", "wcag2aa", "wcag21a", "wcag21aa"]
SERIOUS = ("serious", "critical")

RUN = """async (tags) => {
  const result = await axe.run(document, { runOnly: { type: "tag", values: tags }, resultTypes: ["violations"],
                                          iframes: false });
  return result.violations.map((v) => ({ id: v.id, impact: v.impact, help: v.help,
    nodes: v.nodes.slice(0, 8).map((n) => `${n.target.join(" ")}: ${n.failureSummary.replace(/\\s+/g, " ")}`),
  }));
}"""

# WCAG 2 relative luminance and contrast ratio, for SVG text axe does not judge (the state graph's boxes)
CONTRAST = """(selector) => {
  const rgb = (c) => c.match(/[\\d.]+/g).slice(0, 3).map(Number);
  const lum = (c) => { const [r, g, b] = rgb(c).map((v) => { v /= 255;
    return v <= 0.03928 ? v / 12.92 : ((v + 0.055) / 1.055) ** 2.4; }); return 0.2126 * r + 0.7152 * g + 0.0722 * b; };
  return [...document.querySelectorAll(selector)].map((g) => {
    const text = getComputedStyle(g.querySelector('text')).fill, box = getComputedStyle(g.querySelector('rect')).fill;
    const [a, b] = [lum(text), lum(box)].sort((x, y) => y - x);
    return { state: g.dataset.state, classes: g.getAttribute('class'), ratio: (a + 0.05) / (b + 0.05) };
  });
}"""


def load_axe(page: Any) -> None:
    if not AXE.exists():
        raise AssertionError(f"{AXE} missing: `./run test` installs it (npm ci in tests/axe)")
    page.evaluate(AXE.read_text() + "\n;0")


def serious_violations(page: Any) -> list[dict[str, Any]]:
    """axe-core's WCAG 2.1 A/AA violations of impact serious or critical on the page as it is now."""
    if not page.evaluate("typeof window.axe === 'object'"):
        load_axe(page)
    found: list[dict[str, Any]] = page.evaluate(RUN, WCAG_AA)
    return [v for v in found if v["impact"] in SERIOUS]


def svg_state_contrast(page: Any, selector: str = ".hcm-node") -> list[dict[str, Any]]:
    """Contrast ratio of each drawn state's name against its box."""
    result: list[dict[str, Any]] = page.evaluate(CONTRAST, selector)
    return result
