// HCM state graph, as the HCM exports it (hcm_graph): states on a circle, current highlighted, history with times.

import { esc } from "../dom.js";

const SVG = "http://www.w3.org/2000/svg";

function stampSeconds(t) { return t.sec + t.nanosec * 1e-9; }

export default {
  id: "hcm",
  title: "HCM state graph (focused robot)",
  size: [2, 2],
  create(body, ctx) {
    const { store } = ctx;
    body.innerHTML = `<div class="hcm"><svg viewBox="0 0 600 400" preserveAspectRatio="xMidYMid meet"></svg>
      <div class="history"><b>history</b><ol class="history-list"></ol></div></div>
      <div class="tip" hidden></div>`;
    const svg = body.querySelector("svg");
    const list = body.querySelector(".history-list");
    const tip = body.querySelector(".tip");
    let shownKey = "";
    const offs = [ctx.subscribe("hcm_graph", 5, (f) => { if (f.robot === store.focus) render(); }),
      ctx.subscribe("robot_state", 5, () => {}), store.on("focus", () => { shownKey = ""; render(); })];

    function render() {
      const graph = store.get(store.focus, "hcm_graph")?.data;
      if (!graph) {
        svg.innerHTML = `<text x="300" y="200" text-anchor="middle" class="empty" fill="currentColor">no hcm_graph from ${esc(store.focus || "any robot")}</text>`;
        list.innerHTML = "";
        shownKey = "";
        return;
      }
      const key = JSON.stringify([graph.states, graph.transition_from, graph.transition_to]);
      if (key !== shownKey) { layout(graph); shownKey = key; }
      for (const node of svg.querySelectorAll(".hcm-node")) {
        node.classList.toggle("current", node.dataset.state === graph.current);
      }
      list.innerHTML = graph.history_states.map((s, i) => {
        const t = graph.history_stamps[i] ? new Date(stampSeconds(graph.history_stamps[i]) * 1000) : null;
        return `<li><span class="time">${t ? t.toLocaleTimeString() : ""}</span> ${esc(s)}</li>`;
      }).reverse().join("");
    }

    function layout(graph) {
      const n = graph.states.length;
      const cx = 300, cy = 200, r = Math.min(160, 50 + n * 14);
      const pos = new Map(graph.states.map((s, i) => {
        const a = -Math.PI / 2 + 2 * Math.PI * i / Math.max(1, n);
        return [s, { x: cx + r * Math.cos(a), y: cy + r * Math.sin(a) }];
      }));
      svg.innerHTML = `<defs><marker id="arrow" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="6" markerHeight="6"
        orient="auto-start-reverse"><path d="M0,0 L10,5 L0,10 z" fill="currentColor"/></marker></defs>`;
      const edges = document.createElementNS(SVG, "g");
      svg.append(edges);
      graph.transition_from.forEach((from, i) => {
        const to = graph.transition_to[i];
        const a = pos.get(from), b = pos.get(to);
        if (!a || !b) return;
        const path = document.createElementNS(SVG, "path");
        const dx = b.x - a.x, dy = b.y - a.y, len = Math.hypot(dx, dy) || 1;
        const nodeR = 32;
        const sx = a.x + dx / len * nodeR, sy = a.y + dy / len * nodeR;
        const ex = b.x - dx / len * nodeR, ey = b.y - dy / len * nodeR;
        const bend = 0.15; // curve so A->B and B->A do not overlap
        const mx = (sx + ex) / 2 - dy * bend, my = (sy + ey) / 2 + dx * bend;
        path.setAttribute("d", from === to ? `M${a.x},${a.y - nodeR} a14,14 0 1,1 1,0` : `M${sx},${sy} Q${mx},${my} ${ex},${ey}`);
        path.setAttribute("class", "hcm-edge");
        path.setAttribute("marker-end", "url(#arrow)");
        path.dataset.from = from;
        path.dataset.to = to;
        path.dataset.condition = graph.transition_condition[i] || "";
        edges.append(path);
      });
      for (const s of graph.states) {
        const p = pos.get(s);
        const g = document.createElementNS(SVG, "g");
        g.setAttribute("class", "hcm-node");
        g.dataset.state = s;
        g.innerHTML = `<circle cx="${p.x}" cy="${p.y}" r="32"></circle><text x="${p.x}" y="${p.y}">${esc(short(s))}</text>
          <title>${esc(s)}</title>`;
        g.addEventListener("mouseenter", (e) => hover(s, e));
        g.addEventListener("mouseleave", () => hover(null));
        svg.append(g);
      }
    }

    function hover(state, event) {
      const lines = [];
      for (const edge of svg.querySelectorAll(".hcm-edge")) {
        const on = state !== null && (edge.dataset.from === state || edge.dataset.to === state);
        edge.classList.toggle("active", on);
        if (on) lines.push(`${esc(edge.dataset.from)} → ${esc(edge.dataset.to)}${edge.dataset.condition ? `: ${esc(edge.dataset.condition)}` : ""}`);
      }
      for (const node of svg.querySelectorAll(".hcm-node")) node.classList.toggle("hovered", node.dataset.state === state);
      if (state === null) { tip.hidden = true; return; }
      tip.innerHTML = `<b>${esc(state)}</b><br>${lines.join("<br>") || "no transitions"}`;
      const rect = body.getBoundingClientRect();
      tip.style.left = `${Math.min(event.clientX - rect.left + 12, rect.width - 200)}px`;
      tip.style.top = `${event.clientY - rect.top + 12}px`;
      tip.hidden = false;
    }

    render();
    return { destroy() { offs.forEach((off) => off()); } };
  },
};

function short(state) {
  return state.length > 12 ? `${state.slice(0, 11)}…` : state;
}
