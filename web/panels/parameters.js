// Parameters: every node of a robot with its parameters, edited live (the node validates), undo, diff, save, reset,
// and a small plot of a numeric field (the server lists them) against time with a parameter drawn as a threshold
// line. The panel follows changes made elsewhere (another dashboard, the command line, the node itself) through the
// server's stream of the nodes' parameter events; an input being typed into is never overwritten.

import { api, labToolOff, numericFields, robotPicker } from "../lab_api.js";
import { esc } from "../dom.js";

const PLOT_SECONDS = 20;
const PLOT_HZ = 30;
const DEFAULT_PLOT = ["imu/data", "angular_velocity/y"]; // the fall checker's gyro pitch against its threshold

function pick(obj, path) {
  return path.split("/").reduce((o, k) => (o == null ? undefined : o[k]), obj);
}

function controlFor(p) {
  const dis = "";
  if (p.type === "bool") {
    return `<label class="toggle"><input type="checkbox" data-role="value" ${p.value ? "checked" : ""}${dis}> on</label>`;
  }
  if (p.choices) {
    return `<select data-role="value">${p.choices.map((c) => `<option value="${esc(JSON.stringify(c))}"
      ${c === p.value ? "selected" : ""}>${esc(c)}</option>`).join("")}</select>`;
  }
  if (p.type === "int" || p.type === "float") {
    const step = p.type === "int" ? 1 : "any";
    const slider = p.range ? `<input type="range" data-role="slider" min="${esc(p.range[0])}" max="${esc(p.range[1])}"
      step="${p.type === "int" ? 1 : esc((p.range[1] - p.range[0]) / 200)}" value="${esc(p.value)}">` : "";
    return `${slider}<input type="number" data-role="value" step="${step}" value="${esc(p.value)}">`;
  }
  if (p.type === "list") return `<input type="text" data-role="value" value="${esc(JSON.stringify(p.value))}">`;
  return `<input type="text" data-role="value" value="${esc(p.value)}">`;
}

function readControl(p, row) {
  const el = row.querySelector('[data-role="value"]');
  if (p.type === "bool") return el.checked;
  if (p.choices) return JSON.parse(el.value);
  if (p.type === "int" || p.type === "float") return el.value.trim() === "" ? null : Number(el.value);
  if (p.type === "list") return JSON.parse(el.value);
  return el.value;
}

export default {
  id: "parameters",
  title: "Parameters",
  size: [2, 3],
  hidden: false,
  create(body, ctx) {
    if (labToolOff(body, ctx.config)) return {};
    body.innerHTML = `<div class="lab-bar">
        <label>robot <select data-role="robot"></select></label>
        <button data-act="reload" title="read every node's parameters again">reload</button>
        <button data-act="undo" title="write back the value before your last change" disabled>undo</button>
        <label>model <input data-role="model" value="minibot" size="8" title="robots/&lt;model&gt;/params.yaml for the diff"></label>
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
    const $ = (sel) => body.querySelector(sel);
    const nodesEl = $('[data-role="nodes"]');
    const statusEl = $('[data-role="status"]');
    const undoBtn = $('[data-act="undo"]');
    const state = { robot: "", nodes: {}, undo: [], writes: 0, errors: 0, series: [], events: 0, deferred: new Map() };
    window.pitchside.params = state;
    let source = null; // EventSource of the robot's parameter events, see follow()

    const status = (text, bad = false) => { statusEl.textContent = text; statusEl.classList.toggle("bad", bad); };
    const picker = robotPicker($('[data-role="robot"]'), ctx, (robot) => {
      state.robot = robot; state.series = []; state.deferred.clear(); load(); follow();
    });

    async function load() {
      if (!state.robot) return;
      status("reading…");
      try {
        state.nodes = await api("GET", `api/robots/${encodeURIComponent(state.robot)}/params`);
        render();
        status(`${Object.keys(state.nodes).length} nodes`);
      } catch (err) {
        status(String(err.message), true);
      }
    }

    function render() {
      const names = Object.keys(state.nodes).sort();
      if (!names.length) { nodesEl.innerHTML = '<div class="empty">no node answered</div>'; return; }
      nodesEl.innerHTML = names.map((node) => `<details class="param-node" data-node="${esc(node)}" open>
        <summary>${esc(node)} <button data-act="diff">diff vs YAML</button> <button data-act="save">save</button>
          <button data-act="reset-node">reset all to default</button></summary>
        <div class="param-diff" data-role="diff"></div>
        <table class="grid-table params"><thead><tr><th>name</th><th>value</th><th>default</th><th>range / choices</th>
          <th></th></tr></thead><tbody>${state.nodes[node].map((p) => `
          <tr data-param="${esc(node)}/${esc(p.name)}" title="${esc(p.doc)}">
            <td><b>${esc(p.name)}</b> <span class="muted">${esc(p.type)}</span><div class="muted doc">${esc(p.doc)}</div></td>
            <td class="param-control">${controlFor(p)} <span class="muted" data-role="revision"
              title="revision: how often the value changed since the node started">rev ${esc(p.revision)}</span>
              <div class="param-elsewhere" data-role="elsewhere"></div><div class="param-error" data-role="error"></div></td>
            <td>${esc(JSON.stringify(p.default))}</td>
            <td>${p.range ? `[${p.range[0]}, ${p.range[1]}]` : p.choices ? esc(p.choices.join(", ")) : ""}</td>
            <td><button data-act="reset" title="reset to default">↺</button></td></tr>`).join("")}</tbody></table>
        </details>`).join("");
      refreshThresholds();
    }

    function find(node, name) { return state.nodes[node]?.find((p) => p.name === name); }

    /** Shows a value; an input the user is typing into is left alone unless forced (a refused write reverts). */
    function showValue(node, p, force = false) {
      const row = nodesEl.querySelector(`tr[data-param="${CSS.escape(`${node}/${p.name}`)}"]`);
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

    function applyReply(node, reply) {
      if (reply?.params) state.nodes[node] = reply.params;
      for (const p of state.nodes[node] || []) showValue(node, p);
    }

    // -- following changes made elsewhere ----------------------------------------------------------
    /** The server's stream of the robot's parameter events (every node); reconnects by itself. */
    function follow() {
      source?.close();
      source = null;
      if (!state.robot) return;
      let opened = false;
      source = new EventSource(`api/robots/${encodeURIComponent(state.robot)}/params/*/events`);
      source.onopen = () => { if (opened) refreshValues(); opened = true; }; // reconnected: catch up
      source.onmessage = (e) => { try { applyEvent(JSON.parse(e.data)); } catch (err) { console.warn(err); } };
      source.addEventListener("resync", refreshValues);
    }

    /** Is the user editing this parameter (typing, or holding its slider)? */
    function editing(node, name) {
      const row = nodesEl.querySelector(`tr[data-param="${CSS.escape(`${node}/${name}`)}"]`);
      const active = document.activeElement;
      return Boolean(row && active && row.contains(active) && active.matches("input, select"));
    }

    /** A change made elsewhere: shown at once, unless the user is editing that parameter. Then the panel keeps
     * the revision the user's edit is based on (so writing it is refused as a conflict, as it should be) and shows
     * the other value beside the input until the user leaves it. */
    function applyEvent(event, { authoritative = false } = {}) {
      const params = state.nodes[event.node];
      if (!params) { load(); return; } // a node we have not seen yet
      for (const [name, value] of Object.entries(event.changed || {})) {
        const p = params.find((x) => x.name === name);
        const revision = event.revisions?.[name];
        if (!p || revision === undefined) { refreshValues(); continue; }
        // we already show this or newer (e.g. our own write's reply); a full read is taken as it is (a node that
        // restarted counts its revisions from 0 again)
        if (authoritative ? revision === p.revision && value === p.value : revision <= p.revision) continue;
        const key = `${event.node}/${name}`;
        if (editing(event.node, name)) {
          state.deferred.set(key, { value, revision });
          const note = nodesEl.querySelector(`tr[data-param="${CSS.escape(key)}"] [data-role="elsewhere"]`);
          if (note) note.textContent = `changed elsewhere to ${JSON.stringify(value)} (rev ${revision})`;
          continue;
        }
        Object.assign(p, { value, revision });
        showValue(event.node, p);
      }
      state.events++;
    }

    /** The user left a parameter's input: a change made elsewhere meanwhile is shown now, after any write the
     * input started (that write was based on the revision the user saw, and is refused if it was overtaken). */
    nodesEl.addEventListener("focusout", (e) => {
      const row = e.target.closest("tr[data-param]");
      if (!row) return;
      const key = row.dataset.param;
      writes.then(() => {
        const fresh = state.deferred.get(key);
        if (!fresh || editing(...key.split("/"))) return;
        state.deferred.delete(key);
        row.querySelector('[data-role="elsewhere"]').textContent = "";
        const [node, name] = key.split("/");
        const p = find(node, name);
        if (p && fresh.revision !== p.revision) { Object.assign(p, fresh); showValue(node, p); }
      });
    });

    /** Every node's values again, into the rows already shown (no re-render: inputs keep focus and text). */
    async function refreshValues() {
      if (!state.robot) return;
      try {
        const fresh = await api("GET", `api/robots/${encodeURIComponent(state.robot)}/params`);
        if (Object.keys(fresh).sort().join() !== Object.keys(state.nodes).sort().join()) { state.nodes = fresh; render(); return; }
        for (const [node, params] of Object.entries(fresh)) {
          applyEvent({ node, changed: Object.fromEntries(params.map((p) => [p.name, p.value])),
            revisions: Object.fromEntries(params.map((p) => [p.name, p.revision])) }, { authoritative: true });
        }
      } catch (err) {
        status(String(err.message), true);
      }
    }

    // writes go one after another, so each is based on the revision the previous one's reply brought
    let writes = Promise.resolve();
    function write(node, name, value, options = {}) {
      writes = writes.then(() => writeNow(node, name, value, options));
      return writes;
    }

    /** Writes one value based on the revision we showed; a refusal is shown at the row and the value reverts. */
    async function writeNow(node, name, value, { recordUndo = true } = {}) {
      const p = find(node, name);
      const row = nodesEl.querySelector(`tr[data-param="${CSS.escape(`${node}/${name}`)}"]`);
      const errEl = row?.querySelector('[data-role="error"]');
      if (errEl) errEl.textContent = "";
      row?.classList.remove("refused");
      const old = p.value;
      try {
        const reply = await api("POST", `api/robots/${encodeURIComponent(state.robot)}/params/${encodeURIComponent(node)}`,
          { values: { [name]: value }, revisions: { [name]: p.revision } });
        applyReply(node, reply);
        state.writes++;
        if (recordUndo && old !== value) { state.undo.push({ node, name, value: old }); undoBtn.disabled = false; }
        status(`${node}.${name} = ${JSON.stringify(find(node, name)?.value)}`);
      } catch (err) {
        state.errors++;
        if (errEl) errEl.textContent = err.message;
        row?.classList.add("refused");
        showValue(node, p, true);
        if (err.status === 409) { // someone else changed it meanwhile: show theirs, keep the message
          try {
            const fresh = await api("GET", `api/robots/${encodeURIComponent(state.robot)}/params/${encodeURIComponent(node)}`);
            applyReply(node, { params: fresh });
          } catch { /* the message above is what matters */ }
        }
      }
    }

    nodesEl.addEventListener("change", (e) => {
      const row = e.target.closest("tr[data-param]");
      if (!row) return;
      const [node, name] = row.dataset.param.split("/");
      const p = find(node, name);
      if (e.target.dataset.role === "slider") row.querySelector('[data-role="value"]').value = e.target.value;
      let value;
      try { value = readControl(p, row); } catch (err) {
        row.querySelector('[data-role="error"]').textContent = `not valid: ${err.message}`;
        return;
      }
      write(node, name, value);
    });
    nodesEl.addEventListener("input", (e) => { // the slider shows its number while dragged
      if (e.target.dataset.role === "slider") e.target.closest("tr").querySelector('[data-role="value"]').value = e.target.value;
    });
    nodesEl.addEventListener("click", async (e) => {
      const act = e.target.dataset?.act;
      if (!act) return;
      e.preventDefault();
      const nodeEl = e.target.closest("[data-node]");
      const node = nodeEl?.dataset.node;
      const base = `api/robots/${encodeURIComponent(state.robot)}/params/${encodeURIComponent(node)}`;
      try {
        if (act === "reset") {
          const name = e.target.closest("tr").dataset.param.split("/")[1];
          applyReply(node, await api("POST", `${base}/reset`, { names: [name] }));
        } else if (act === "reset-node") {
          applyReply(node, await api("POST", `${base}/reset`, { names: [] }));
        } else if (act === "save") {
          const reply = await api("POST", `${base}/save`);
          status(`saved to ${reply.path}`);
        } else if (act === "diff") {
          const diff = await api("GET", `${base}/diff?model=${encodeURIComponent($('[data-role="model"]').value)}`);
          nodeEl.querySelector('[data-role="diff"]').innerHTML = diff.changes.length
            ? `<table class="grid-table"><tr><th>${esc(diff.file)}</th><th>file / default</th><th>live</th></tr>${diff.changes
              .map((c) => `<tr data-diff="${esc(c.name)}"><td>${esc(c.name)}</td><td>${esc(JSON.stringify(c.yaml))}
              <span class="muted">${esc(c.from)}</span></td><td><b>${esc(JSON.stringify(c.live))}</b></td></tr>`).join("")}</table>`
            : `<div class="muted">live values match ${esc(diff.file)}</div>`;
        }
      } catch (err) {
        status(err.message, true);
      }
    });
    undoBtn.addEventListener("click", async () => {
      const last = state.undo.pop();
      undoBtn.disabled = !state.undo.length;
      if (last) await write(last.node, last.name, last.value, { recordUndo: false });
    });
    $('[data-act="reload"]').addEventListener("click", load);

    // -- threshold plot ---------------------------------------------------------------------------
    const fieldSel = $('[data-role="field"]');
    const thresholdSel = $('[data-role="threshold"]');
    const canvas = $('[data-role="plot"]');
    function refreshThresholds() {
      const keep = thresholdSel.value;
      const opts = ['<option value="">(none)</option>'];
      for (const [node, params] of Object.entries(state.nodes)) {
        for (const p of params) {
          if (p.type === "float" || p.type === "int") opts.push(`<option value="${esc(node)}/${esc(p.name)}">${esc(node)}.${esc(p.name)}</option>`);
        }
      }
      thresholdSel.innerHTML = opts.join("");
      thresholdSel.value = keep || (find("hcm", "falling_gyro_pitch") ? "hcm/falling_gyro_pitch" : "");
    }
    // any numeric field of any topic of the robot: topics from the server's list of the robot's streams, fields
    // from the newest message of the chosen topic
    const topicSel = $('[data-role="topic"]');
    const bothSigns = $('[data-role="both-signs"]');
    const plot = { topic: "", field: "", off: null, fieldsOf: "" };
    state.plot = plot;
    function robotTopics() {
      const info = ctx.store.robots.find((r) => r.robot === state.robot);
      const topics = new Set(Object.entries(info?.streams ?? {})
        .filter(([, st]) => !/Image$/.test(st.msgtype ?? "")).map(([t]) => t));
      for (const [t, frame] of ctx.store.latest.get(state.robot) ?? []) if (frame.type === "msg") topics.add(t);
      if (plot.topic) topics.add(plot.topic);
      return [...topics].sort();
    }
    function refreshTopics() {
      const topics = robotTopics();
      const html = topics.map((t) => `<option value="${esc(t)}">${esc(t)}</option>`).join("");
      if (topicSel.innerHTML !== html) topicSel.innerHTML = html;
      if (!plot.topic && topics.includes(DEFAULT_PLOT[0])) chooseTopic(DEFAULT_PLOT[0], DEFAULT_PLOT[1]);
      topicSel.value = plot.topic;
    }
    /** The topic's numeric fields, from the server (the one definition of a numeric field), once the robot's first
     * message of the topic is there; asked again for another robot or topic. */
    async function refreshFields() {
      const { topic } = plot, robot = state.robot, key = `${robot}|${topic}`;
      if (plot.fieldsOf === key) return;
      plot.fieldsOf = key;
      let fields;
      try { fields = await numericFields(robot, topic); } catch {
        if (plot.fieldsOf === key) plot.fieldsOf = ""; // no message yet: the next frame asks again
        return;
      }
      if (plot.topic !== topic || state.robot !== robot) return;
      fieldSel.innerHTML = '<option value="">field…</option>' +
        fields.map((f) => `<option value="${esc(f.path)}">${esc(f.label)}</option>`).join("");
      if (!plot.field && topic === DEFAULT_PLOT[0] && fields.some((f) => f.path === DEFAULT_PLOT[1])) plot.field = DEFAULT_PLOT[1];
      fieldSel.value = plot.field;
    }
    function chooseTopic(topic, field = "") {
      plot.off?.();
      Object.assign(plot, { topic, field, off: null, fieldsOf: "" });
      state.series = [];
      fieldSel.innerHTML = '<option value="">field…</option>';
      if (!topic) return;
      plot.off = ctx.subscribe(topic, PLOT_HZ, (frame) => {
        if (frame.robot !== state.robot || frame.type !== "msg" || frame.topic !== plot.topic) return;
        refreshFields();
        const v = plot.field ? pick(frame.data, plot.field) : undefined;
        if (typeof v !== "number") return;
        const now = performance.now() / 1000;
        state.series.push([now, v]);
        while (state.series.length && state.series[0][0] < now - PLOT_SECONDS) state.series.shift();
      });
      const latest = ctx.store.get(state.robot, topic);
      if (latest?.type === "msg") refreshFields();
    }
    topicSel.addEventListener("change", () => chooseTopic(topicSel.value));
    fieldSel.addEventListener("change", () => { plot.field = fieldSel.value; state.series = []; });
    const offs = [ctx.store.on("robots", refreshTopics), () => plot.off?.()];
    refreshTopics();

    function draw() {
      if (!body.querySelector(".lab-plot").open) return;
      const w = canvas.clientWidth, h = canvas.clientHeight;
      if (canvas.width !== w) canvas.width = w;
      const g = canvas.getContext("2d");
      const css = getComputedStyle(body);
      g.clearRect(0, 0, w, h);
      const [tn, tp] = thresholdSel.value ? thresholdSel.value.split("/") : [];
      const line = tn ? find(tn, tp)?.value : undefined;
      const lines = line === undefined ? [] : bothSigns.checked ? [line, -line] : [line];
      const values = [0, ...state.series.map((s) => s[1]), ...lines];
      let lo = Math.min(...values), hi = Math.max(...values);
      const pad = Math.max(1e-3, (hi - lo) * 0.05);
      lo -= pad; hi += pad;
      const y = (v) => h - 4 - ((v - lo) / (hi - lo)) * (h - 8);
      const now = performance.now() / 1000;
      g.strokeStyle = css.getPropertyValue("--muted");
      g.beginPath(); g.moveTo(0, y(0)); g.lineTo(w, y(0)); g.stroke();
      g.strokeStyle = css.getPropertyValue("--accent");
      g.lineWidth = 2;
      g.beginPath();
      state.series.forEach(([t, v], i) => {
        const x = w - ((now - t) / PLOT_SECONDS) * w;
        if (i) g.lineTo(x, y(v)); else g.moveTo(x, y(v));
      });
      g.stroke();
      g.fillStyle = css.getPropertyValue("--fg");
      if (state.series.length) g.fillText(`${plot.topic} ${plot.field} = ${state.series.at(-1)[1].toPrecision(4)}`, 4, 10);
      if (lines.length) {
        g.strokeStyle = css.getPropertyValue("--bad");
        g.setLineDash([6, 4]);
        for (const v of lines) { g.beginPath(); g.moveTo(0, y(v)); g.lineTo(w, y(v)); g.stroke(); }
        g.setLineDash([]);
        g.fillStyle = css.getPropertyValue("--bad");
        g.fillText(`${tp} = ${line}`, 4, y(line) - 3);
      }
      g.lineWidth = 1;
      // what is drawn, for tests and the curious: the plotted field, its newest value and the lines' pixel rows
      state.drawn = { topic: plot.topic, field: plot.field, points: state.series.length,
        last: state.series.at(-1)?.[1], lines, lineRows: lines.map((v) => Math.round(y(v))) };
    }
    const timer = setInterval(draw, 200);
    return { destroy() { clearInterval(timer); picker.off(); offs.forEach((off) => off()); source?.close(); } };
  },
};
