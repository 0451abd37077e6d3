// A state machine graph panel for StateMachineGraph topics (the HCM's, the behaviour's; a menu chooses which one when
// it shows several): the server lays the graph out with Graphviz (GET api/state-graphs/<robot>/<topic>), this module
// draws it, marks the current state and the last transitions, and names a transition's triggers on hover. Names are
// set as text nodes only.

import { expose, hooks } from "../test_hooks.js";
import { KEYS, getText, setText } from "../settings.js";

const SVG = "http://www.w3.org/2000/svg";
const PAD = 8; // points around the drawing, so a box's border is never cut by the panel's edge
const MIN_FONT_PX = 11; // below this a state name is not readable at the side of the pitch: scroll instead
const MAX_SCALE = 1.6;
const RECENT = 3; // transitions of the history drawn as "recent" (the newest as "last")

function stampSeconds(t) { return t.sec + t.nanosec * 1e-9; }

function svgEl(name, attrs = {}) {
  const el = document.createElementNS(SVG, name);
  for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, v);
  return el;
}

/** The transitions the history went through, newest last: [[from, to], ...]. */
export function recentTransitions(historyStates, count = RECENT) {
  const pairs = [];
  for (let i = 1; i < historyStates.length; i++) {
    if (historyStates[i - 1] !== historyStates[i]) pairs.push([historyStates[i - 1], historyStates[i]]);
  }
  return pairs.slice(-count);
}

/** A panel module drawing a StateMachineGraph stream of the focused robot: `topic`, or one of `topics` ([topic,
 * label] pairs) chosen in the panel (the choice is remembered in this browser). */
/** @param {{id: string, title: string, topic?: string, topics?: string[][], size?: number[]}} options */
export function stateGraphPanel({ id, title, topic: only, topics = [[only, only]], size = [2, 2] }) {
  return {
    id, title, size,
    create(body, ctx) {
      const { store } = ctx;
      const remembered = KEYS.stateGraph + id;
      let topic = topics.find(([t]) => t === getText(remembered))?.[0] ?? topics[0][0];
      body.classList.add("state-graph-body");
      const bar = document.createElement("div");
      bar.className = "graph-bar";
      const chooser = document.createElement("select");
      chooser.className = "graph-topic";
      chooser.setAttribute("aria-label", "which state machine");
      chooser.replaceChildren(...topics.map(([t, label]) => new Option(label, t)));
      chooser.value = topic;
      bar.append(chooser);
      bar.hidden = topics.length < 2;
      const root = document.createElement("div");
      root.className = "state-graph hcm";
      const view = document.createElement("div");
      view.className = "graph-view";
      // in a small panel the graph scrolls: reachable by keyboard too (arrow keys scroll it once focused)
      view.tabIndex = 0;
      view.setAttribute("role", "region");
      view.setAttribute("aria-label", `${title} graph`);
      const history = document.createElement("div");
      history.className = "history";
      const heading = document.createElement("b");
      heading.textContent = "history";
      const list = document.createElement("ol");
      list.className = "history-list";
      history.append(heading, list);
      root.append(view, history);
      const tip = document.createElement("div");
      tip.className = "tip";
      tip.hidden = true;
      body.append(bar, root, tip);

      let shape = "";     // the drawn graph's states and transitions (JSON)
      let asked = "";     // the shape a layout was last asked for (robot + shape)
      let drawing = null; // {svg, layout, scale}
      const shown = { robot: "", topic, scale: 0, fontPx: 0, error: "" }; // for tests and the README's pictures
      const graphs = hooks().stateGraphs ?? {};
      if (!hooks().stateGraphs) expose("stateGraphs", graphs);
      graphs[id] = shown;

      const follow = (t) => ctx.subscribe(t, 5, (f) => { if (f.robot === store.focus && t === topic) render(); });
      let following = follow(topic);
      const offs = [store.on("focus", () => { shape = ""; asked = ""; render(); })];
      chooser.addEventListener("change", () => {
        following();
        topic = chooser.value;
        setText(remembered, topic);
        following = follow(topic);
        shape = ""; asked = ""; drawing = null;
        shown.topic = topic; shown.robot = "";
        render();
      });
      const resizer = new ResizeObserver(() => fit());
      resizer.observe(view);

      function message(text) {
        const p = document.createElement("p");
        p.className = "empty";
        p.textContent = text;
        view.replaceChildren(p);
        drawing = null;
        shown.scale = 0;
      }

      function render() {
        const robot = store.focus;
        const graph = store.get(robot, topic)?.data;
        if (!graph) {
          message(`no ${topic} from ${robot || "any robot"}`);
          list.replaceChildren();
          shape = ""; asked = "";
          return;
        }
        const key = JSON.stringify([graph.states, graph.transition_from, graph.transition_to,
          graph.transition_condition]);
        if (key !== shape && `${robot}|${key}` !== asked) fetchLayout(robot, key);
        if (drawing) highlight(graph);
        showHistory(graph);
      }

      async function fetchLayout(robot, key) {
        asked = `${robot}|${key}`;
        const wanted = topic;
        try {
          const answer = await fetch(`api/state-graphs/${encodeURIComponent(robot)}/${wanted}`);
          const data = await answer.json();
          if (asked !== `${robot}|${key}` || robot !== store.focus || wanted !== topic) return; // focus/graph moved
          if (!answer.ok) throw new Error(data.detail ?? answer.statusText);
          shape = key;
          shown.robot = robot;
          shown.error = "";
          draw(data);
          const graph = store.get(robot, topic)?.data;
          if (graph) highlight(graph);
        } catch (err) {
          if (asked !== `${robot}|${key}`) return;
          shown.error = String(err.message ?? err);
          message(`state graph of ${robot} not drawn: ${shown.error}`);
          asked = ""; // ask again with the next message
        }
      }

      function draw(layout) {
        const width = layout.width + 2 * PAD, height = layout.height + 2 * PAD;
        const svg = svgEl("svg", { viewBox: `${-PAD} ${-PAD} ${width} ${height}`, role: "img",
          "font-family": `"${layout.font_family}", "DejaVu Sans", Verdana, sans-serif`,
          "font-size": layout.font_size });
        const label = document.createElementNS(SVG, "title");
        label.textContent = `${layout.machine} state graph of ${layout.robot}`;
        svg.append(label);
        const edges = svgEl("g", { class: "edges" });
        for (const t of layout.transitions) {
          const g = svgEl("g", { class: "hcm-transition" });
          const [[bx, by], [tx, ty]] = t.head;
          const len = Math.hypot(tx - bx, ty - by) || 1, nx = -(ty - by) / len * 3.5, ny = (tx - bx) / len * 3.5;
          const path = svgEl("path", { d: t.path, class: "hcm-edge" });
          const head = svgEl("polygon", { class: "hcm-head",
            points: `${tx},${ty} ${bx + nx},${by + ny} ${bx - nx},${by - ny}` });
          const hit = svgEl("path", { d: t.path, class: "hcm-edge-hit" });
          for (const el of [path, head, hit]) { el.dataset.from = t.from_state; el.dataset.to = t.to_state; }
          path.dataset.condition = t.conditions.join(" / ");
          hit.addEventListener("mouseenter", (e) => hoverEdge(t, e));
          hit.addEventListener("mouseleave", () => hoverEdge(null));
          g.append(path, head, hit);
          edges.append(g);
        }
        const nodes = svgEl("g", { class: "states" });
        for (const s of layout.states) {
          const g = svgEl("g", { class: "hcm-node" });
          g.dataset.state = s.name;
          const rect = svgEl("rect", { x: s.x, y: s.y, width: s.width, height: s.height, rx: 6 });
          const text = svgEl("text", { x: s.x + s.width / 2, y: s.y + s.height / 2 });
          text.textContent = s.name;
          g.append(rect, text);
          g.addEventListener("mouseenter", (e) => hoverState(s.name, e));
          g.addEventListener("mouseleave", () => hoverState(null));
          nodes.append(g);
        }
        svg.append(edges, nodes);
        view.replaceChildren(svg);
        // a browser without DejaVu Sans draws wider letters than dot measured: squeeze such a name into its box
        for (const g of nodes.children) {
          const rect = g.firstChild, text = g.lastChild, room = Number(rect.getAttribute("width")) - 6;
          if (text.getComputedTextLength() > room) {
            text.setAttribute("textLength", room);
            text.setAttribute("lengthAdjust", "spacingAndGlyphs");
          }
        }
        drawing = { svg, layout, width, height };
        fit();
      }

      /** As large as the panel allows, but never so small that a name drops below MIN_FONT_PX (then it scrolls). */
      function fit() {
        if (!drawing) return;
        const { svg, layout, width, height } = drawing;
        const room = Math.min((view.clientWidth - 2) / width, (view.clientHeight - 2) / height);
        const scale = Math.min(MAX_SCALE, Math.max(MIN_FONT_PX / layout.font_size, room));
        svg.setAttribute("width", Math.floor(width * scale));
        svg.setAttribute("height", Math.floor(height * scale));
        shown.scale = scale;
        shown.fontPx = layout.font_size * scale;
      }

      function highlight(graph) {
        const recent = recentTransitions(graph.history_states ?? []);
        const rank = new Map(recent.map(([a, b], i) => [`${a}\u0000${b}`, i === recent.length - 1 ? "last" : "recent"]));
        for (const el of drawing.svg.querySelectorAll(".hcm-edge, .hcm-head")) {
          const mark = rank.get(`${el.dataset.from}\u0000${el.dataset.to}`);
          el.classList.toggle("recent", mark === "recent");
          el.classList.toggle("last", mark === "last");
        }
        const previous = recent.length ? recent[recent.length - 1][0] : null;
        for (const node of drawing.svg.querySelectorAll(".hcm-node")) {
          node.classList.toggle("current", node.dataset.state === graph.current);
          node.classList.toggle("previous", node.dataset.state === previous && previous !== graph.current);
        }
      }

      function showHistory(graph) {
        const items = (graph.history_states ?? []).map((s, i) => {
          const li = document.createElement("li");
          const time = document.createElement("span");
          time.className = "time";
          const stamp = graph.history_stamps?.[i];
          time.textContent = stamp ? new Date(stampSeconds(stamp) * 1000).toLocaleTimeString() : "";
          li.append(time, ` ${s}`);
          return li;
        });
        list.replaceChildren(...items.reverse());
      }

      function showTip(lines, event) {
        tip.replaceChildren();
        lines.forEach((line, i) => {
          if (i) tip.append(document.createElement("br"));
          if (i === 0) { const b = document.createElement("b"); b.textContent = line; tip.append(b); }
          else tip.append(line);
        });
        const rect = body.getBoundingClientRect();
        tip.style.left = `${Math.max(0, Math.min(event.clientX - rect.left + 12, rect.width - 330))}px`;
        tip.style.top = `${event.clientY - rect.top + 12}px`;
        tip.hidden = false;
      }

      function transitionLine(from, to, condition) {
        return `${from} → ${to}${condition ? `: ${condition}` : ""}`;
      }

      function hoverState(state, event) {
        if (!drawing) return;
        const lines = [];
        for (const edge of drawing.svg.querySelectorAll(".hcm-edge")) {
          const on = state !== null && (edge.dataset.from === state || edge.dataset.to === state);
          edge.classList.toggle("active", on);
          if (on) lines.push(transitionLine(edge.dataset.from, edge.dataset.to, edge.dataset.condition));
        }
        for (const node of drawing.svg.querySelectorAll(".hcm-node")) {
          node.classList.toggle("hovered", node.dataset.state === state);
        }
        if (state === null) { tip.hidden = true; return; }
        showTip([state, ...(lines.length ? lines : ["no transitions"])], event);
      }

      function hoverEdge(transition, event) {
        if (!drawing) return;
        for (const edge of drawing.svg.querySelectorAll(".hcm-edge")) {
          edge.classList.toggle("active", transition !== null && edge.dataset.from === transition.from_state
            && edge.dataset.to === transition.to_state);
        }
        if (transition === null) { tip.hidden = true; return; }
        showTip([`${transition.from_state} → ${transition.to_state}`,
          ...transition.conditions.map((c) => `when ${c || "(no condition given)"}`)], event);
      }

      render();
      return {
        resize: fit,
        destroy() {
          following();
          offs.forEach((off) => off());
          resizer.disconnect();
          delete graphs[id];
        },
      };
    },
  };
}
