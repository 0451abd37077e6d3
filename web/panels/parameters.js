// Parameters: every node of a robot with its parameters, found by a search across nodes, edited live (the node
// validates), reset to the default or reverted to the YAML file, saved into that file (its comments stay), undone
// exactly, compared with the file (diff); and a small plot of a numeric field (the server lists them) against time
// with a parameter drawn as a threshold line. The panel follows changes made elsewhere (another dashboard, the
// command line, the node itself) through the server's stream of the nodes' parameter events; an input being typed
// into is never overwritten, and the panel's own writes are never taken for changes made elsewhere.
// One panel object holds the state; each function below renders one part or handles one user action.

import { defaultsOf, describeValues, differing, find, pick, same, typedValue } from "../models/param_table.js";
import { expose } from "../test_hooks.js";
import { api, labToolOff, numericFields, robotPath, robotPicker } from "../lab_api.js";
import { esc, statusLine } from "../dom.js";
import { matches } from "../param_search.js";

const PLOT_SECONDS = 20;
const PLOT_HZ = 30;
const DEFAULT_PLOT = ["imu/data", "angular_velocity/y"]; // the fall checker's gyro pitch against its threshold

/** The input that fits a parameter's type: a toggle, a menu of its choices, a number (with a slider in a range). */
function controlFor(p) {
  // a start-up parameter (e.g. the joint limits) changes only in the parameter file: shown, not editable
  const lock = p.startup ? ' disabled title="read once when its node starts: change it in the parameter file"' : "";
  if (p.type === "bool") {
    return `<label class="toggle"><input type="checkbox" data-role="value"${lock} aria-label="${esc(p.name)}"
      ${p.value ? "checked" : ""}> on</label>`;
  }
  if (p.choices) {
    return `<select data-role="value"${lock} aria-label="${esc(p.name)}">${p.choices.map((c) => `<option value="${esc(JSON.stringify(c))}"
      ${c === p.value ? "selected" : ""}>${esc(c)}</option>`).join("")}</select>`;
  }
  if (p.type === "int" || p.type === "float") {
    const step = p.type === "int" ? 1 : "any";
    const slider = p.range ? `<input type="range" data-role="slider"${lock} aria-label="${esc(p.name)} (slider)" min="${esc(p.range[0])}" max="${esc(p.range[1])}"
      step="${p.type === "int" ? 1 : esc((p.range[1] - p.range[0]) / 200)}" value="${esc(p.value)}">` : "";
    return `${slider}<input type="number" data-role="value"${lock} aria-label="${esc(p.name)}" step="${step}"
      value="${esc(p.value)}">`;
  }
  const label = `aria-label="${esc(p.name)}"`;
  if (p.type === "list") return `<input type="text" data-role="value"${lock} ${label} value="${esc(JSON.stringify(p.value))}">`;
  return `<input type="text" data-role="value"${lock} ${label} value="${esc(p.value)}">`;
}

/** The value a parameter's input holds, in the parameter's type; throws on a list or choice that is not JSON. */
function readControl(p, row) {
  return typedValue(p, /** @type {HTMLInputElement} */ (row.querySelector('[data-role="value"]')));
}

// The panel's markup; the nodes' tables are rendered into data-role="nodes".
const LAYOUT = `<div class="lab-bar">
        <input type="search" data-role="search" placeholder="find a parameter…" size="18"
          title="node.name as shown (walking.step), words of the description, or a unit (m, rad, hz; speed, angle); Enter goes to the first one found, Esc clears">
        <span class="muted" data-role="found"></span>
        <label>robot <select data-role="robot"></select></label>
        <button data-act="reload" title="read every node's parameters again">reload</button>
        <button data-act="undo" title="nothing to undo" disabled>undo</button>
        <label>model <input data-role="model" value="minibot" size="8"
          title="robots/&lt;model&gt;/params.yaml: the file compared with for a node started without one"></label>
        <span class="lab-status" data-role="status"></span>
      </div>
      <details class="lab-plot"><summary>threshold plot</summary>
        <div class="lab-bar"><label>topic <select data-role="topic" title="any topic of the robot"></select></label>
        <label>field <select data-role="field" title="any numeric field of the topic"></select></label>
        <label>line <select data-role="threshold"><option value="">(none)</option></select></label>
        <label title="draw the line at +value and -value (a threshold on a magnitude, e.g. the gyro's)">
          <input type="checkbox" data-role="both-signs" checked> ±</label></div>
        <canvas data-role="plot" height="140"></canvas>
      </details>
      <div data-role="nodes"><div class="empty">waiting for a robot</div></div>`;

export default {
  id: "parameters",
  title: "Parameters",
  size: [2, 3],
  hidden: false,
  create(body, ctx) {
    if (labToolOff(body, ctx.config)) return {};
    body.innerHTML = LAYOUT;
    const pp = newPanel(body, ctx);
    const { el } = pp;
    expose("params", pp.state);
    pp.picker = robotPicker(pp.$('[data-role="robot"]'), ctx, (robot) => chooseRobot(pp, robot));
    el.nodes.addEventListener("focusout", (e) => onLeaveInput(pp, e));
    el.nodes.addEventListener("change", (e) => onValueChange(pp, e));
    el.nodes.addEventListener("input", onSliderInput);
    el.nodes.addEventListener("click", (e) => onNodeAction(pp, e));
    el.search.addEventListener("input", () => { clearErrors(pp); applyFilter(pp); });
    el.search.addEventListener("keydown", (e) => onSearchKey(pp, e));
    el.undo.addEventListener("click", () => undoLast(pp));
    pp.$('[data-act="reload"]').addEventListener("click", () => load(pp));
    el.topic.addEventListener("change", () => chooseTopic(pp, el.topic.value));
    el.field.addEventListener("change", () => { pp.plot.field = el.field.value; pp.state.series = []; });
    const offs = [ctx.store.on("robots", () => refreshTopics(pp)), () => pp.plot.off?.()];
    refreshTopics(pp);
    const timer = setInterval(() => draw(pp), 200);
    return { destroy() { clearInterval(timer); pp.picker.off(); offs.forEach((off) => off()); pp.source?.close(); } };
  },
};

/** The panel: its state (window.pitchside.params, for tests), its elements, the event stream and the write queue. */
function newPanel(body, ctx) {
  const $ = (sel) => body.querySelector(sel);
  // undo: what the panel's accepted changes replaced, newest last; inflight: "node/name" -> the value a write of
  // the panel is sending (its event may come before its reply, and is not a change made elsewhere)
  const state = { robot: "", nodes: {}, undo: [], writes: 0, errors: 0, series: [], events: 0, deferred: new Map(),
    inflight: new Map(), ownEvents: 0 };
  // the threshold plot: any numeric field of any topic of the robot
  state.plot = { topic: "", field: "", off: null, fieldsOf: "" };
  return {
    body, ctx, $, state, plot: state.plot, picker: null,
    el: { nodes: $('[data-role="nodes"]'), undo: $('[data-act="undo"]'), topic: $('[data-role="topic"]'),
      field: $('[data-role="field"]'), threshold: $('[data-role="threshold"]'), search: $('[data-role="search"]'),
      found: $('[data-role="found"]'), bothSigns: $('[data-role="both-signs"]'), canvas: $('[data-role="plot"]') },
    status: statusLine($('[data-role="status"]')),
    source: null, // EventSource of the robot's parameter events, see follow()
    writeQueue: Promise.resolve(), // see write()
  };
}

/** The robot's parameter path (its node's, given one). */
function paramsPath(pp, node) {
  const path = `${robotPath(pp.state.robot)}/params`;
  return node === undefined ? path : `${path}/${encodeURIComponent(node)}`;
}

/** Another robot chosen: its parameters are read and followed, the plot starts afresh, undo forgets the other's. */
function chooseRobot(pp, robot) {
  const { state } = pp;
  state.robot = robot; state.series = []; state.deferred.clear(); state.undo = []; showUndo(pp);
  load(pp); follow(pp);
}

/** Every node's parameters, read and shown anew. quiet: a reading the user did not ask for (a node that came
 * later) leaves the status line alone, which may say what the user's last change did. */
async function load(pp, { quiet = false } = {}) {
  const { state } = pp;
  if (!state.robot) return;
  if (!quiet) pp.status("reading…");
  try {
    state.nodes = await api("GET", paramsPath(pp));
    render(pp);
    if (!quiet) pp.status(`${Object.keys(state.nodes).length} nodes`);
  } catch (err) {
    pp.status(String(err.message), true);
  }
}

// -- rendering ------------------------------------------------------------------------------------

/** One section per node, sorted by name, filtered by the search; the threshold menu follows the numeric ones. */
function render(pp) {
  const { state, el } = pp;
  const names = Object.keys(state.nodes).sort();
  if (!names.length) { el.nodes.innerHTML = '<div class="empty">no node answered</div>'; return; }
  el.nodes.innerHTML = names.map((node) => nodeSection(node, state.nodes[node])).join("");
  applyFilter(pp);
  refreshThresholds(pp);
}

// what a node's buttons do, as their tooltips say
const TIPS = {
  diff: "the live values that differ from the node's YAML file",
  save: "write the live values into the node's YAML file (only the changed ones: its comments and order stay)",
  revert: "every parameter back to its value in the node's YAML file (asks first; undo takes it back)",
  reset: "every parameter back to its default (asks first; undo takes it back)",
};

/** A node's section: its buttons (diff, save, revert, reset), the place for the diff, and its parameters' table. */
function nodeSection(node, params) {
  return `<details class="param-node" data-node="${esc(node)}" open>
        <summary>${esc(node)}</summary>
        <div class="param-node-acts"><button data-act="diff" title="${esc(TIPS.diff)}">diff vs file</button>
          <button data-act="save" title="${esc(TIPS.save)}">save</button>
          <button data-act="revert-node" title="${esc(TIPS.revert)}">revert all to file</button>
          <button data-act="reset-node" title="${esc(TIPS.reset)}">reset all to default</button></div>
        <div class="param-diff" data-role="diff"></div>
        <table class="grid-table params"><colgroup><col class="c-name"><col class="c-value"><col class="c-default">
          <col class="c-range"><col class="c-acts"></colgroup>
          <thead><tr><th>name</th><th>value</th><th>default</th><th>range / choices</th><th>back to</th></tr></thead>
          <tbody>${params.map((p) => paramRow(node, p)).join("")}</tbody></table>
        </details>`;
}

/** A parameter's row: name, type and doc, its input with revision and notes, default, range or choices, and the
 * two ways back: to the YAML file's value and to the default. */
function paramRow(node, p) {
  return `
          <tr data-param="${esc(node)}/${esc(p.name)}" title="${esc(p.doc)}">
            <td><b>${esc(p.name)}</b> <span class="muted">${esc(p.type)}</span><div class="muted doc">${esc(p.doc)}</div></td>
            <td class="param-control">${controlFor(p)} <span class="muted" data-role="revision"
              title="revision: how often the value changed since the node started">rev ${esc(p.revision)}</span>
              <div class="param-elsewhere" data-role="elsewhere"></div><div class="param-error" data-role="error"></div></td>
            <td>${esc(JSON.stringify(p.default))}</td>
            <td>${p.range ? `[${esc(p.range[0])}, ${esc(p.range[1])}]` : p.choices ? esc(p.choices.join(", ")) : ""}</td>
            <td class="param-acts"><button data-act="revert" title="revert to the value in the YAML file">file</button>
              <button data-act="reset" title="reset to default">default</button></td></tr>`;
}

/** A parameter as the panel holds it. */

/** The row of a parameter ("node/name"), if shown. */
function rowOf(pp, key) {
  return pp.el.nodes.querySelector(`tr[data-param="${CSS.escape(key)}"]`);
}

/** Shows a value; an input the user is typing into is left alone unless forced (a refused write reverts). */
function showValue(pp, node, p, force = false) {
  const row = rowOf(pp, `${node}/${p.name}`);
  if (!row) return;
  const rev = row.querySelector('[data-role="revision"]');
  if (rev) rev.textContent = `rev ${p.revision}`;
  const el = row.querySelector('[data-role="value"]');
  if (el === document.activeElement && !force) return;
  if (p.type === "bool") el.checked = p.value;
  else if (p.choices) el.value = JSON.stringify(p.value);
  else if (p.type === "list") el.value = JSON.stringify(p.value);
  else el.value = p.value;
  const slider = row.querySelector('[data-role="slider"]');
  if (slider) slider.value = p.value;
}

/** A node's reply (its parameters after a write) into the panel and the rows. */
function applyReply(pp, node, reply) {
  if (reply?.params) pp.state.nodes[node] = reply.params;
  for (const p of pp.state.nodes[node] || []) showValue(pp, node, p);
}

// -- search ---------------------------------------------------------------------------------------

/** Only the parameters the search names (web/param_search.js: the dotted node.name, words of the description,
 * units); nodes without one fold away, the others open. */
function applyFilter(pp) {
  const { el, state } = pp;
  const query = el.search.value.trim();
  let shown = 0, total = 0;
  for (const section of el.nodes.querySelectorAll("[data-node]")) {
    let inNode = 0;
    for (const row of section.querySelectorAll("tr[data-param]")) {
      const [node, name] = row.dataset.param.split("/");
      const hit = matches(query, node, find(state, node, name) ?? { name });
      row.hidden = !hit;
      inNode += Number(hit); total++;
    }
    section.hidden = !inNode;
    if (query && inNode) section.open = true;
    shown += inNode;
  }
  el.found.textContent = query ? `${shown} of ${total}` : "";
}

/** The next action of the user: the notes of what went wrong before (the status line's, the rows') go. */
function clearErrors(pp) {
  if (pp.$('[data-role="status"]').classList.contains("bad")) pp.status("");
  clearRefusals(pp);
}

/** Enter in the search goes to the first parameter found (its text selected, ready to be typed over); Esc clears. */
function onSearchKey(pp, e) {
  if (e.key === "Escape") { pp.el.search.value = ""; clearErrors(pp); applyFilter(pp); return; }
  if (e.key !== "Enter") return;
  e.preventDefault();
  clearErrors(pp);
  const first = pp.el.nodes.querySelector("tr[data-param]:not([hidden])");
  const input = first?.querySelector('[data-role="value"]');
  if (!input) { pp.status(`no parameter matches "${pp.el.search.value}"`, true); return; }
  first.scrollIntoView({ block: "nearest" });
  input.focus();
  input.select?.();
}

// -- following changes made elsewhere ----------------------------------------------------------

/** The server's stream of the robot's parameter events (every node); reconnects by itself. */
function follow(pp) {
  pp.source?.close();
  pp.source = null;
  if (!pp.state.robot) return;
  let opened = false;
  const source = pp.source = new EventSource(`${paramsPath(pp)}/*/events`);
  source.onopen = () => { if (opened) refreshValues(pp); opened = true; }; // reconnected: catch up
  source.onmessage = (e) => { try { applyEvent(pp, JSON.parse(e.data)); } catch (err) { console.warn(err); } };
  source.addEventListener("resync", () => refreshValues(pp));
}

/** Is the user editing this parameter (typing, or holding its slider)? */
function editing(pp, node, name) {
  const row = rowOf(pp, `${node}/${name}`);
  const active = document.activeElement;
  return Boolean(row && active && row.contains(active) && active.matches("input, select"));
}

/** A change made elsewhere: shown at once, unless the user is editing that parameter. Then the panel keeps
 * the revision the user's edit is based on (so writing it is refused as a conflict, as it should be) and shows
 * the other value beside the input until the user leaves it. The event of the panel's own write (it may come
 * before the write's reply) is taken as the reply. */
function applyEvent(pp, event, { authoritative = false } = {}) {
  const { state } = pp;
  const params = state.nodes[event.node];
  if (!params) { load(pp, { quiet: true }); return; } // a node we have not seen yet
  for (const [name, value] of Object.entries(event.changed || {})) {
    const p = params.find((x) => x.name === name);
    const revision = event.revisions?.[name];
    const key = `${event.node}/${name}`;
    if (!p || revision === undefined) { refreshValues(pp); continue; }
    // we already show this or newer (e.g. our own write's reply); a full read is taken as it is (a node that
    // restarted counts its revisions from 0 again)
    if (authoritative ? revision === p.revision && value === p.value : revision <= p.revision) continue;
    if (state.inflight.has(key) && same(state.inflight.get(key), value)) {
      Object.assign(p, { value, revision }); // our own write: the input shows it already
      showValue(pp, event.node, p);
      state.ownEvents++;
      continue;
    }
    if (editing(pp, event.node, name)) { defer(pp, key, value, revision); continue; }
    Object.assign(p, { value, revision });
    showValue(pp, event.node, p);
  }
  state.events++;
}

/** A change made elsewhere while the user edits the parameter: kept, and noted beside the input. */
function defer(pp, key, value, revision) {
  pp.state.deferred.set(key, { value, revision });
  const note = rowOf(pp, key)?.querySelector('[data-role="elsewhere"]');
  if (note) note.textContent = `changed elsewhere to ${JSON.stringify(value)} (rev ${revision})`;
}

/** The user left a parameter's input: a change made elsewhere meanwhile is shown now, after any write the
 * input started (that write was based on the revision the user saw, and is refused if it was overtaken). */
function onLeaveInput(pp, e) {
  const row = e.target.closest("tr[data-param]");
  if (!row) return;
  const key = row.dataset.param;
  pp.writeQueue.then(() => {
    const fresh = pp.state.deferred.get(key);
    if (!fresh || editing(pp, ...key.split("/"))) return;
    pp.state.deferred.delete(key);
    row.querySelector('[data-role="elsewhere"]').textContent = "";
    const [node, name] = key.split("/");
    const p = find(pp.state, node, name);
    if (p && fresh.revision > p.revision) { Object.assign(p, fresh); showValue(pp, node, p); }
  });
}

/** Every node's values again, into the rows already shown (no re-render: inputs keep focus and text). */
async function refreshValues(pp) {
  const { state } = pp;
  if (!state.robot) return;
  try {
    const fresh = await api("GET", paramsPath(pp));
    if (Object.keys(fresh).sort().join() !== Object.keys(state.nodes).sort().join()) {
      state.nodes = fresh; render(pp); return;
    }
    for (const [node, params] of Object.entries(fresh)) {
      applyEvent(pp, { node, changed: Object.fromEntries(params.map((p) => [p.name, p.value])),
        revisions: Object.fromEntries(params.map((p) => [p.name, p.revision])) }, { authoritative: true });
    }
  } catch (err) {
    pp.status(String(err.message), true);
  }
}

// -- writing --------------------------------------------------------------------------------------

/** Queues a write: writes go one after another, so each is based on the revision the previous one's reply brought.
 * Resolves to whether the node took it. */
function write(pp, node, values, options = {}) {
  const done = pp.writeQueue.then(() => writeNow(pp, node, values, options));
  pp.writeQueue = done.catch(() => false);
  return done;
}

/** Writes values of one node in one request based on the revisions we showed (or those given: an undo is based
 * on the revisions its change produced), so the node takes all or none. Accepted: the values the write replaced
 * go onto the undo stack (unless it is an undo), old refusal notes go. Refused: the reason at the row (or in the
 * status line for several), the values shown revert. */
async function writeNow(pp, node, values, { recordUndo = true, revisions = null, what = "" } = {}) {
  const { state } = pp;
  const names = Object.keys(values);
  const before = Object.fromEntries(names.map((n) => [n, find(state, node, n)?.value]));
  const based = revisions ?? Object.fromEntries(names.map((n) => [n, find(state, node, n)?.revision]));
  const rows = names.map((n) => rowOf(pp, `${node}/${n}`)).filter(Boolean);
  clearErrors(pp); // a new change: what went wrong before no longer describes the panel
  for (const n of names) state.inflight.set(`${node}/${n}`, values[n]);
  try {
    const reply = await api("POST", paramsPath(pp, node), { values, revisions: based });
    applyReply(pp, node, reply);
    state.writes++;
    clearRefusals(pp);
    const changed = reply.changed ?? names;
    if (recordUndo && changed.length) {
      state.undo.push({ node, values: Object.fromEntries(changed.map((n) => [n, before[n]])), what,
        based: Object.fromEntries(changed.map((n) => [n, based[n]])),
        revisions: Object.fromEntries(changed.map((n) => [n, find(state, node, n)?.revision])) });
      showUndo(pp);
    }
    refreshShownDiff(pp, node);
    const now = Object.fromEntries(names.map((n) => [n, find(state, node, n)?.value]));
    pp.status(`${what ? `${what}: ` : ""}${describeValues(node, now)}`);
    return true;
  } catch (err) {
    state.errors++;
    for (const row of rows) row.classList.add("refused");
    if (rows.length === 1) rows[0].querySelector('[data-role="error"]').textContent = err.message;
    pp.status(`${what ? `${what} refused: ` : ""}${err.message}`, true);
    for (const n of names) { const p = find(state, node, n); if (p) showValue(pp, node, p, true); }
    if (err.status === 409) { // someone else changed it meanwhile: show theirs, keep the message
      try {
        applyReply(pp, node, { params: await api("GET", paramsPath(pp, node)) });
      } catch { /* the message above is what matters */ }
    }
    return false;
  } finally {
    for (const n of names) state.inflight.delete(`${node}/${n}`);
  }
}

/** The notes of earlier refusals go once a later change is accepted: they no longer describe the panel. */
function clearRefusals(pp) {
  for (const row of pp.el.nodes.querySelectorAll("tr.refused")) {
    row.classList.remove("refused");
    row.querySelector('[data-role="error"]').textContent = "";
  }
}

/** An input changed: its value (read in the parameter's type) is written; one that does not parse is refused. */
function onValueChange(pp, e) {
  const row = e.target.closest("tr[data-param]");
  if (!row) return;
  const [node, name] = row.dataset.param.split("/");
  const p = find(pp.state, node, name);
  if (e.target.dataset.role === "slider") row.querySelector('[data-role="value"]').value = e.target.value;
  let value;
  try { value = readControl(p, row); } catch (err) {
    row.querySelector('[data-role="error"]').textContent = `not valid: ${err.message}`;
    return;
  }
  write(pp, node, { [name]: value });
}

/** The slider shows its number while dragged. */
function onSliderInput(e) {
  if (e.target.dataset.role !== "slider") return;
  e.target.closest("tr").querySelector('[data-role="value"]').value = e.target.value;
}

/** The undo button says what it would write back. */
function showUndo(pp) {
  const last = pp.state.undo.at(-1);
  pp.el.undo.disabled = !last;
  pp.el.undo.title = last ? `undo${last.what ? ` ${last.what}` : ""}: back to ${describeValues(last.node, last.values)}`
    : "nothing to undo";
}

/** "undo": the values the panel's last accepted change replaced are written back exactly, based on the revisions
 * that change produced: if someone changed one of them since, the undo is refused (and dropped) rather than
 * overwriting their value. Not itself undoable; the change before it can be undone next. */
async function undoLast(pp) {
  const { state } = pp;
  const last = state.undo.pop();
  showUndo(pp);
  if (!last) return;
  if (!await write(pp, last.node, last.values, { recordUndo: false, revisions: last.revisions, what: "undo" })) return;
  // the undo wrote the very value an earlier change produced, at a new revision: that change stays undoable
  for (const name of Object.keys(last.values)) {
    const earlier = state.undo.findLast((u) => u.node === last.node && name in u.values);
    if (earlier?.revisions[name] === last.based[name]) earlier.revisions[name] = find(state, last.node, name)?.revision;
  }
}

/** The node's values that differ from its YAML file ({name: file value}) and the file's name, from the diff. */
async function fileValues(pp, node) {
  const model = encodeURIComponent(pp.$('[data-role="model"]').value);
  const diff = await api("GET", `${paramsPath(pp, node)}/diff?model=${model}`);
  return { file: diff.file, values: Object.fromEntries(diff.changes.map((c) => [c.name, c.yaml])), diff };
}

/** The values of a node that differ from those given ({name: value}), for a reset or revert to write. */
function differingNow(pp, node, targets) {
  return differing(pp.state.nodes[node] ?? [], targets);
}

/** A node's defaults ({name: default}), all or of the named parameter. */
function defaults(pp, node, name) {
  return defaultsOf(pp.state.nodes[node] ?? [], name);
}

/** Writes a node's values back (a reset or a revert) as one undoable write; for more than one, asks first. */
async function writeBack(pp, node, values, what, askFirst) {
  const count = Object.keys(values).length;
  if (!count) { pp.status(`${what}: nothing to change`); return; }
  const list = Object.entries(values)
    .map(([n, v]) => `  ${n}: ${JSON.stringify(find(pp.state, node, n)?.value)} → ${JSON.stringify(v)}`);
  const question = `${what}: change ${count} parameter${count > 1 ? "s" : ""} of ${node}?\n${list.join("\n")}`;
  if (askFirst && !window.confirm(question)) {
    pp.status(`${what}: cancelled, nothing changed`);
    return;
  }
  await write(pp, node, values, { what });
}

/** Shows the node's diff (its live values against its YAML file) under its buttons. */
async function showDiff(pp, node) {
  const { diff } = await fileValues(pp, node);
  const place = pp.el.nodes.querySelector(`[data-node="${CSS.escape(node)}"] [data-role="diff"]`);
  if (place) place.innerHTML = diffTable(diff);
  return diff;
}

/** A diff on screen is redone after the panel changed the node's values, so it never shows stale ones. */
function refreshShownDiff(pp, node) {
  const place = pp.el.nodes.querySelector(`[data-node="${CSS.escape(node)}"] [data-role="diff"]`);
  if (place?.innerHTML.trim()) showDiff(pp, node).catch(() => { place.innerHTML = ""; });
}

/** A node's buttons (data-act) by name, each given the panel, the click and the node. */
const NODE_ACTIONS = {
  async reset(pp, e, node) {
    const name = e.target.closest("tr").dataset.param.split("/")[1];
    const values = differingNow(pp, node, defaults(pp, node, name));
    await writeBack(pp, node, values, `${node}.${name} reset to default`, false);
  },
  async revert(pp, e, node) {
    const name = e.target.closest("tr").dataset.param.split("/")[1];
    const { file, values } = await fileValues(pp, node);
    if (!(name in values)) { pp.status(`${node}.${name} is as in ${file}`); return; }
    await writeBack(pp, node, { [name]: values[name] }, `${node}.${name} reverted to ${file}`, false);
  },
  async "reset-node"(pp, e, node) {
    await writeBack(pp, node, differingNow(pp, node, defaults(pp, node)), `reset ${node} to defaults`, true);
  },
  async "revert-node"(pp, e, node) {
    const { file, values } = await fileValues(pp, node);
    await writeBack(pp, node, values, `revert ${node} to ${file}`, true);
  },
  async save(pp, e, node) {
    const saved = await api("POST", `${paramsPath(pp, node)}/save`);
    const diff = await showDiff(pp, node);
    const left = diff.changes.length ? `; ${diff.changes.length} still differ` : "";
    pp.status(`saved ${node} to ${saved.path} at ${new Date().toLocaleTimeString()}${left}`);
  },
  async diff(pp, e, node) { await showDiff(pp, node); },
};

/** A node's buttons (and a row's): summary buttons must not fold the node, so the click is taken. */
async function onNodeAction(pp, e) {
  const act = e.target.dataset?.act;
  if (!act) return;
  e.preventDefault();
  const node = e.target.closest("[data-node]")?.dataset.node;
  try {
    if (Object.hasOwn(NODE_ACTIONS, act)) await NODE_ACTIONS[act](pp, e, node);
  } catch (err) {
    pp.status(err.message, true);
  }
}

/** The node's live values that differ from its YAML file (or its defaults). */
function diffTable(diff) {
  return diff.changes.length
    ? `<table class="grid-table"><tr><th>${esc(diff.file)}</th><th>file / default</th><th>live</th></tr>${diff.changes
      .map((c) => `<tr data-diff="${esc(c.name)}"><td>${esc(c.name)}</td><td>${esc(JSON.stringify(c.yaml))}
              <span class="muted">${esc(c.from)}</span></td><td><b>${esc(JSON.stringify(c.live))}</b></td></tr>`).join("")}</table>`
    : `<div class="muted" data-role="matches">live values match ${esc(diff.file)}</div>`;
}

// -- threshold plot -------------------------------------------------------------------------------

/** The line menu: every numeric parameter; the fall checker's gyro threshold until the user picks another. */
function refreshThresholds(pp) {
  const select = pp.el.threshold;
  const keep = select.value;
  const opts = ['<option value="">(none)</option>'];
  for (const [node, params] of Object.entries(pp.state.nodes)) {
    for (const p of params) {
      if (p.type !== "float" && p.type !== "int") continue;
      opts.push(`<option value="${esc(node)}/${esc(p.name)}">${esc(node)}.${esc(p.name)}</option>`);
    }
  }
  select.innerHTML = opts.join("");
  select.value = keep || (find(pp.state, "hcm", "falling_gyro_pitch") ? "hcm/falling_gyro_pitch" : "");
}

/** The robot's topics: from the server's list of its streams (images left out) and from what has arrived. */
function robotTopics(pp) {
  const { ctx, state, plot } = pp;
  const info = ctx.store.robots.find((r) => r.robot === state.robot);
  const topics = new Set(Object.entries(info?.streams ?? {})
    .filter(([, st]) => !/Image$/.test(st.msgtype ?? "")).map(([t]) => t));
  for (const [t, frame] of ctx.store.latest.get(state.robot) ?? []) if (frame.type === "msg") topics.add(t);
  if (plot.topic) topics.add(plot.topic);
  return [...topics].sort();
}

/** The topic menu, redrawn only when it changed; the gyro is chosen once it is there. */
function refreshTopics(pp) {
  const { el, plot } = pp;
  const topics = robotTopics(pp);
  const html = topics.map((t) => `<option value="${esc(t)}">${esc(t)}</option>`).join("");
  if (el.topic.innerHTML !== html) el.topic.innerHTML = html;
  if (!plot.topic && topics.includes(DEFAULT_PLOT[0])) chooseTopic(pp, DEFAULT_PLOT[0], DEFAULT_PLOT[1]);
  el.topic.value = plot.topic;
}

/** The topic's numeric fields, from the server (the one definition of a numeric field), once the robot's first
 * message of the topic is there; asked again for another robot or topic. */
async function refreshFields(pp) {
  const { plot, state, el } = pp;
  const { topic } = plot, robot = state.robot, key = `${robot}|${topic}`;
  if (plot.fieldsOf === key) return;
  plot.fieldsOf = key;
  let fields;
  try { fields = await numericFields(robot, topic); } catch {
    if (plot.fieldsOf === key) plot.fieldsOf = ""; // no message yet: the next frame asks again
    return;
  }
  if (plot.topic !== topic || state.robot !== robot) return;
  el.field.innerHTML = '<option value="">field…</option>' +
    fields.map((f) => `<option value="${esc(f.path)}">${esc(f.label)}</option>`).join("");
  const offersDefault = topic === DEFAULT_PLOT[0] && fields.some((f) => f.path === DEFAULT_PLOT[1]);
  if (!plot.field && offersDefault) plot.field = DEFAULT_PLOT[1];
  el.field.value = plot.field;
}

/** Another topic to plot: the old subscription ends, the series starts afresh. */
function chooseTopic(pp, topic, field = "") {
  const { plot, state, ctx } = pp;
  plot.off?.();
  Object.assign(plot, { topic, field, off: null, fieldsOf: "" });
  state.series = [];
  pp.el.field.innerHTML = '<option value="">field…</option>';
  if (!topic) return;
  plot.off = ctx.subscribe(topic, PLOT_HZ, (frame) => onPlotSample(pp, frame));
  const latest = ctx.store.get(state.robot, topic);
  if (latest?.type === "msg") refreshFields(pp);
}

/** A message of the plotted topic: its field's number joins the series, which keeps PLOT_SECONDS. */
function onPlotSample(pp, frame) {
  const { plot, state } = pp;
  if (frame.robot !== state.robot || frame.type !== "msg" || frame.topic !== plot.topic) return;
  refreshFields(pp);
  const v = plot.field ? pick(frame.data, plot.field) : undefined;
  if (typeof v !== "number") return;
  const now = performance.now() / 1000;
  state.series.push([now, v]);
  while (state.series.length && state.series[0][0] < now - PLOT_SECONDS) state.series.shift();
}

/** Every 200 ms while the plot is open: zero, the series, and the threshold line (at ± it if asked). */
function draw(pp) {
  const { body, state, plot, el } = pp;
  if (!body.querySelector(".lab-plot").open) return;
  const canvas = el.canvas;
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== w) canvas.width = w;
  const g = canvas.getContext("2d");
  const css = getComputedStyle(body);
  g.clearRect(0, 0, w, h);
  const [tn, tp] = el.threshold.value ? el.threshold.value.split("/") : [];
  const line = tn ? find(state, tn, tp)?.value : undefined;
  const lines = line === undefined ? [] : el.bothSigns.checked ? [line, -line] : [line];
  const values = [0, ...state.series.map((s) => s[1]), ...lines];
  let lo = Math.min(...values), hi = Math.max(...values);
  const pad = Math.max(1e-3, (hi - lo) * 0.05);
  lo -= pad; hi += pad;
  const y = (v) => h - 4 - ((v - lo) / (hi - lo)) * (h - 8);
  drawSeries(g, css, pp, w, y);
  if (lines.length) drawLines(g, css, lines, `${tp} = ${line}`, w, y);
  g.lineWidth = 1;
  // what is drawn, for tests and the curious: the plotted field, its newest value and the lines' pixel rows
  state.drawn = { topic: plot.topic, field: plot.field, points: state.series.length,
    last: state.series.at(-1)?.[1], lines, lineRows: lines.map((v) => Math.round(y(v))) };
}

/** The zero line, the field's series (newest at the right edge) and its newest value. */
function drawSeries(g, css, pp, w, y) {
  const { series } = pp.state;
  const now = performance.now() / 1000;
  g.strokeStyle = css.getPropertyValue("--muted");
  g.beginPath(); g.moveTo(0, y(0)); g.lineTo(w, y(0)); g.stroke();
  g.strokeStyle = css.getPropertyValue("--accent");
  g.lineWidth = 2;
  g.beginPath();
  series.forEach(([t, v], i) => {
    const x = w - ((now - t) / PLOT_SECONDS) * w;
    if (i) g.lineTo(x, y(v)); else g.moveTo(x, y(v));
  });
  g.stroke();
  g.fillStyle = css.getPropertyValue("--fg");
  if (series.length) g.fillText(`${pp.plot.topic} ${pp.plot.field} = ${series.at(-1)[1].toPrecision(4)}`, 4, 10);
}

/** The threshold line(s), dashed in the warning colour, labelled at the first. */
function drawLines(g, css, lines, label, w, y) {
  g.strokeStyle = css.getPropertyValue("--bad");
  g.setLineDash([6, 4]);
  for (const v of lines) { g.beginPath(); g.moveTo(0, y(v)); g.lineTo(w, y(v)); g.stroke(); }
  g.setLineDash([]);
  g.fillStyle = css.getPropertyValue("--bad");
  g.fillText(label, 4, y(lines[0]) - 3);
}
