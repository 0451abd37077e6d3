// Animation editor and recorder: open/upload a Bit-Bots animation, edit keyframes (structure edits run server-side
// through robot_nodes.animation.editing), record poses from the robot in RECORD, preview in 3D, play, stop, save.

import { api, labToolOff, robotPicker } from "../lab_api.js";
import { esc } from "../dom.js";

const SEND_EVERY_MS = 100; // record goals while a slider is dragged
const RESEND_MS = 300; // in RECORD the held pose is sent again and again: a lost message costs nothing
const GHOSTS_AFTER_MS = 150; // keyframe ghosts follow edits and the selection, at most this often

function torqueLabel(v) { return v === undefined ? "" : v >= 0.5 ? "on" : "off"; }

export default {
  id: "animation",
  title: "Animation editor",
  size: [2, 4],
  create(body, ctx) {
    if (labToolOff(body, ctx.config)) return {};
    body.innerHTML = `<div class="lab-bar">
        <label>robot <select data-role="robot"></select></label>
        <select data-role="files" title="animation files in the robot's animation folder"></select>
        <button data-act="open">open</button>
        <label title="upload a Bit-Bots JSON file">upload <input type="file" data-role="upload" accept=".json,application/json"></label>
        <input data-role="new-name" placeholder="new name" size="10"><button data-act="new">new</button>
      </div>
      <div class="lab-bar">
        <label>file <input data-role="file" size="12"></label>
        <label>name <input data-role="name" size="12"></label>
        <label>author <input data-role="author" size="8"></label>
        <button data-act="save">save</button>
        <button data-act="undo" disabled>undo</button><button data-act="redo" disabled>redo</button>
        <button data-act="insert" title="a new keyframe after the selected one, posed where that one ends">+ keyframe</button>
        <button data-act="mirror" title="swap left and right in the selected keyframe">mirror kf</button>
        <button data-act="mirror-all">mirror all</button>
        <button data-act="invert" title="play backwards">invert</button>
      </div>
      <div class="lab-bar">
        <button data-act="preview" title="ghost robot in the 3D view; the robot does not move">preview 3D</button>
        <label title="still, faint ghosts of the keyframes in the 3D view (the selected one stronger)">ghosts
          <select data-role="ghosts"><option value="off">off</option><option value="near">selected ±1</option>
            <option value="all">all keyframes</option></select></label>
        <button data-act="play" title="save, then play on the robot">▶ play</button>
        <button data-act="play-upto" title="save, then play up to the selected keyframe">▶ to selected</button>
        <button data-act="stop" class="stop" title="cancel the animation and leave RECORD">■ STOP</button>
        <span class="lab-status" data-role="status"></span>
      </div>
      <ul class="anim-warnings" data-role="warnings"></ul>
      <table class="grid-table keyframes"><thead><tr><th>#</th><th>name</th><th>duration s</th><th>pause s</th>
        <th>joints</th><th></th></tr></thead><tbody data-role="keyframes"></tbody></table>
      <div data-role="detail" class="kf-detail"></div>
      <details class="record" data-role="record-box"><summary>record from the robot</summary>
        <div class="lab-bar">
          <button data-act="record-on">RECORD on</button><button data-act="record-off">RECORD off</button>
          <button data-act="record-kf" title="insert the robot's current pose after the selected keyframe">record keyframe</button>
          <button data-act="rec-all">record all joints</button><button data-act="rec-none">none</button>
        </div>
        <table class="grid-table"><thead><tr><th>joint</th><th>rec</th><th>limp</th><th>goal (deg)</th></tr></thead>
          <tbody data-role="joints"></tbody></table>
      </details>`;
    const $ = (sel) => body.querySelector(sel);
    const state = {
      robot: "", file: "", anim: null, selected: -1, undo: [], redo: [], check: null, joints: [],
      held: {}, limp: new Set(), recordJoints: new Set(), recordOn: false, lastError: "", saved: 0,
      ghosts: "off", ghostsShown: 0, ghostsFor: "",
    };
    window.pitchside.animEditor = state;
    let ghostTimer = null, ghostBusy = false, ghostAgain = false; // keyframe ghosts, see sendGhosts
    const base = () => `api/robots/${encodeURIComponent(state.robot)}`;
    const statusEl = $('[data-role="status"]');
    const status = (text, bad = false) => {
      statusEl.textContent = text; statusEl.classList.toggle("bad", bad);
      if (bad) state.lastError = text;
    };
    async function guarded(fn) {
      try { await fn(); } catch (err) { status(err.message, true); }
    }

    const picker = robotPicker($('[data-role="robot"]'), ctx, (robot) => {
      clearGhosts();
      state.robot = robot;
      guarded(async () => { await listFiles(); await loadJoints(); });
      scheduleGhosts();
    });

    async function listFiles() {
      if (!state.robot) return;
      const list = await api("GET", `${base()}/animations`);
      $('[data-role="files"]').innerHTML = list.animations.map((a) => `<option value="${esc(a.file)}">${esc(a.file)}${
        a.error ? " (broken)" : ""}</option>`).join("");
      if (list.animations.some((a) => a.file === state.file)) $('[data-role="files"]').value = state.file;
      state.folder = list.folder;
    }

    async function loadJoints() {
      if (!state.robot) return;
      state.joints = (await api("GET", `${base()}/animations/joints`)).joints;
      if (!state.recordJoints.size) state.joints.forEach((j) => state.recordJoints.add(j.name));
      renderJoints();
    }

    // -- the animation and its history ---------------------------------------------------------------
    function setAnimation(anim, check, { history = true } = {}) {
      if (history && state.anim) { state.undo.push(JSON.stringify(state.anim)); state.redo = []; }
      state.anim = anim;
      if (state.selected >= anim.keyframes.length) state.selected = anim.keyframes.length - 1;
      if (check) state.check = check;
      render();
      if (!check) guarded(runCheck);
    }
    async function runCheck() {
      state.check = await api("POST", `${base()}/animation-check`, { animation: state.anim });
      renderWarnings();
    }
    function edited() { // a field changed in place: history was pushed before
      state.redo = [];
      render();
      guarded(runCheck);
    }
    function snapshot() { if (state.anim) state.undo.push(JSON.stringify(state.anim)); }
    /** An undo/redo step: the animation as it was, the selection kept inside it. */
    function restore(text) {
      state.anim = JSON.parse(text);
      const n = state.anim.keyframes.length;
      state.selected = Math.min(Math.max(state.selected, n ? 0 : -1), n - 1);
      render();
    }
    /** The pose the animation holds at the end of keyframe k: every goal up to k, the newest per joint. */
    function poseAfter(k) {
      const pose = {};
      for (const kf of state.anim.keyframes.slice(0, k + 1)) Object.assign(pose, kf.goals);
      return pose;
    }
    async function insertKeyframe() {
      if (!state.anim) throw new Error("open, upload or start a new animation first");
      const index = state.selected + 1;
      await edit("insert", { index, keyframe: { duration: 1.0, pause: 0.0, goals: poseAfter(state.selected), torque: {} } });
      state.selected = index;
      render();
      status(`inserted keyframe ${index}`);
    }

    async function edit(op, extra = {}) {
      const reply = await api("POST", `${base()}/animation-edit`, { animation: state.anim, op, ...extra });
      setAnimation(reply.animation, reply.check);
      return reply;
    }

    async function open(file) {
      const reply = await api("GET", `${base()}/animations/${encodeURIComponent(file)}`);
      state.file = reply.file;
      state.undo = []; state.redo = []; state.selected = reply.animation.keyframes.length ? 0 : -1;
      setAnimation(reply.animation, reply.check, { history: false });
      status(`opened ${reply.file}`);
    }

    async function save() {
      syncMeta();
      const file = $('[data-role="file"]').value.trim() || state.anim.name;
      const reply = await api("PUT", `${base()}/animations/${encodeURIComponent(file)}`,
        { animation: state.anim, author: $('[data-role="author"]').value || state.anim.author || "" });
      state.file = reply.file;
      state.anim = reply.animation;
      state.check = reply.check;
      state.saved++;
      render();
      status(`saved ${reply.path}`);
      await listFiles();
    }

    function syncMeta() {
      if (!state.anim) return;
      const name = $('[data-role="name"]').value.trim();
      if (name) state.anim.name = name;
    }

    // -- keyframe ghosts in 3D -----------------------------------------------------------------------
    // one request at a time, the newest state wins; the server replaces the ghosts it showed before
    function ghostKeyframes() {
      const n = state.anim?.keyframes.length ?? 0;
      if (state.ghosts === "all") return [...Array(n).keys()];
      const s = state.selected;
      return s < 0 ? [] : [s - 1, s, s + 1].filter((k) => k >= 0 && k < n);
    }
    function scheduleGhosts() {
      if (state.ghosts === "off" || !state.robot) return;
      if (!ghostTimer) ghostTimer = setTimeout(sendGhosts, GHOSTS_AFTER_MS);
    }
    async function sendGhosts() {
      ghostTimer = null;
      if (ghostBusy) { ghostAgain = true; return; }
      if (state.ghosts === "off" || !state.robot) return;
      ghostBusy = true;
      const robot = state.robot;
      state.ghostsFor = robot; // from now on the server may hold ghosts of this robot: clean them up on leaving
      try {
        const animation = state.anim ?? { name: "none", keyframes: [] };
        const r = await api("POST", `${base()}/animation-ghosts`, { animation, keyframes: ghostKeyframes(),
          selected: state.selected });
        state.ghostsShown = r.keyframes.length;
        state.ghostUpdates = (state.ghostUpdates || 0) + 1;
        if (state.ghosts === "off" || state.robot !== robot) clearGhosts(); // switched off while under way
      } catch (err) {
        status(`keyframe ghosts: ${err.message}`, true);
        state.ghosts = "off"; $('[data-role="ghosts"]').value = "off";
      }
      ghostBusy = false;
      if (ghostAgain) { ghostAgain = false; sendGhosts(); }
    }
    /** Removes the ghosts from the 3D view (switched off, another robot, the editor closed). */
    function clearGhosts({ leaving = false } = {}) {
      if (!state.ghostsFor) return;
      const robot = state.ghostsFor;
      state.ghostsFor = ""; state.ghostsShown = 0;
      const path = `api/robots/${encodeURIComponent(robot)}/animation-ghosts`;
      api("DELETE", path, undefined, { keepalive: leaving }).catch((err) => {
        if (!leaving) status(`keyframe ghosts: ${err.message}`, true);
      });
    }

    // -- rendering ------------------------------------------------------------------------------------
    function render() {
      const anim = state.anim;
      $('[data-role="file"]').value = state.file;
      $('[data-role="name"]').value = anim?.name ?? "";
      if (anim && document.activeElement !== $('[data-role="author"]')) $('[data-role="author"]').value = anim.author ?? "";
      $('[data-act="undo"]').disabled = !state.undo.length;
      $('[data-act="redo"]').disabled = !state.redo.length;
      const rows = anim ? anim.keyframes.map((kf, i) => `<tr data-kf="${i}" class="${i === state.selected ? "selected" : ""}">
        <td>${i}</td><td><input data-field="name" value="${esc(kf.name ?? "")}" size="8"></td>
        <td><input type="number" step="0.05" min="0" data-field="duration" value="${esc(kf.duration)}"></td>
        <td><input type="number" step="0.05" min="0" data-field="pause" value="${esc(kf.pause)}"></td>
        <td>${Object.keys(kf.goals).length}</td>
        <td><button data-kact="up" title="move up">↑</button><button data-kact="down" title="move down">↓</button>
          <button data-kact="duplicate" title="duplicate">dup</button><button data-kact="delete" title="delete">✕</button></td>
        </tr>`).join("") : "";
      $('[data-role="keyframes"]').innerHTML = rows || '<tr><td colspan="6" class="empty">open, upload or start a new animation</td></tr>';
      renderDetail();
      renderWarnings();
      scheduleGhosts();
    }

    function renderWarnings() {
      const c = state.check;
      $('[data-role="warnings"]').innerHTML = c ? [...c.errors.map((e) => `<li class="bad">${esc(e)}</li>`),
        ...c.warnings.map((w) => `<li class="warn">${esc(w)}</li>`)].join("") : "";
    }

    function renderDetail() {
      const kf = state.anim?.keyframes[state.selected];
      const el = $('[data-role="detail"]');
      if (!kf) { el.innerHTML = ""; return; }
      const missing = state.joints.filter((j) => !(j.name in kf.goals));
      el.innerHTML = `<b>keyframe ${state.selected}</b> goals (deg) and torque
        <table class="grid-table"><tbody>${Object.entries(kf.goals).map(([j, v]) => `<tr data-joint="${esc(j)}">
          <td>${esc(j)}</td><td><input type="number" step="0.5" data-goal value="${esc(v)}"></td>
          <td><select data-torque><option value="">torque unchanged</option>
            <option value="1" ${torqueLabel(kf.torque?.[j]) === "on" ? "selected" : ""}>torque on</option>
            <option value="0" ${torqueLabel(kf.torque?.[j]) === "off" ? "selected" : ""}>torque off</option></select></td>
          <td><button data-remove title="remove this joint from the keyframe">✕</button></td></tr>`).join("")}</tbody></table>
        ${missing.length ? `<select data-role="add-joint">${missing.map((j) => `<option>${esc(j.name)}</option>`).join("")}</select>
        <button data-act="add-joint">add joint</button>` : ""}`;
    }

    function renderJoints() {
      $('[data-role="joints"]').innerHTML = state.joints.map((j) => `<tr data-joint="${esc(j.name)}">
        <td>${esc(j.name)}</td>
        <td><input type="checkbox" data-rec ${state.recordJoints.has(j.name) ? "checked" : ""}></td>
        <td><input type="checkbox" data-limp ${state.limp.has(j.name) ? "checked" : ""}></td>
        <td><input type="range" data-slider min="${esc(j.lower)}" max="${esc(j.upper)}" step="0.5"
          value="${esc(state.held[j.name] ?? 0)}">
          <input type="number" data-held step="0.5" value="${(state.held[j.name] ?? 0).toFixed(1)}"></td></tr>`).join("");
    }

    // -- recording ------------------------------------------------------------------------------------
    // one request in flight at a time, so goals reach the robot in the order they were made; the newest wins
    let lastSent = 0, pending = null, inFlight = false, again = false;
    function sendGoals(now = false) {
      const go = async () => {
        pending = null;
        if (inFlight) { again = true; return; }
        const positions = {};
        for (const [j, v] of Object.entries(state.held)) if (!state.limp.has(j)) positions[j] = v;
        if (!Object.keys(positions).length && !state.limp.size) return;
        inFlight = true; lastSent = performance.now();
        await guarded(() => api("POST", `${base()}/record/goals`, { positions, limp: [...state.limp] }));
        state.goalsSent = (state.goalsSent || 0) + 1;
        inFlight = false;
        if (again) { again = false; go(); }
      };
      if (now || performance.now() - lastSent > SEND_EVERY_MS) go();
      else if (!pending) pending = setTimeout(go, SEND_EVERY_MS);
    }
    async function recordMode(on) {
      state.recordOn = false;
      if (on) { // hold the pose the robot is in, so nothing jumps when RECORD starts
        const pose = (await api("GET", `${base()}/record/pose`)).positions;
        state.held = {};
        for (const j of state.joints) if (j.name in pose) state.held[j.name] = pose[j.name];
        renderJoints();
      }
      await api("POST", `${base()}/record`, { on });
      state.recordOn = on;
      status(on ? "RECORD: move the sliders (or the limp joints by hand), then record keyframes" : "RECORD off");
    }
    async function recordKeyframe() {
      const pose = (await api("GET", `${base()}/record/pose`)).positions;
      const goals = {};
      for (const j of state.joints) if (state.recordJoints.has(j.name) && j.name in pose) goals[j.name] = Math.round(pose[j.name] * 100) / 100;
      if (!state.anim) state.anim = { name: $('[data-role="new-name"]').value || "recorded", keyframes: [] };
      const index = state.selected + 1;
      await edit("insert", { index, keyframe: { duration: 1.0, pause: 0.0, goals, torque: {} } });
      state.selected = index;
      render();
      status(`recorded keyframe ${index} (${Object.keys(goals).length} joints)`);
    }
    state.recordKeyframe = () => guarded(recordKeyframe);

    // -- events ---------------------------------------------------------------------------------------
    body.addEventListener("click", (e) => {
      const act = e.target.dataset?.act;
      const kact = e.target.dataset?.kact;
      const row = e.target.closest("tr[data-kf]");
      if (row && !kact && e.target.tagName !== "INPUT") { state.selected = +row.dataset.kf; render(); }
      if (kact) {
        const i = +row.dataset.kf;
        guarded(async () => {
          if (kact === "up" && i > 0) { await edit("move", { index: i, new_index: i - 1 }); state.selected = i - 1; }
          if (kact === "down" && i < state.anim.keyframes.length - 1) { await edit("move", { index: i, new_index: i + 1 }); state.selected = i + 1; }
          if (kact === "duplicate") { await edit("duplicate", { index: i }); state.selected = i + 1; }
          if (kact === "delete") {
            await edit("delete", { index: i });
            if (i < state.selected) state.selected--; // the selection stays on its keyframe
          }
          render();
        });
        return;
      }
      if (e.target.dataset?.remove !== undefined && e.target.closest("[data-role=detail]")) {
        snapshot();
        const kf = state.anim.keyframes[state.selected];
        const j = e.target.closest("tr").dataset.joint;
        delete kf.goals[j];
        if (kf.torque) delete kf.torque[j];
        edited();
        return;
      }
      if (!act) return;
      guarded(async () => {
        if (act === "open") await open($('[data-role="files"]').value);
        else if (act === "new") {
          const name = $('[data-role="new-name"]').value.trim() || "new_animation";
          state.file = name; state.undo = []; state.redo = []; state.selected = -1;
          setAnimation({ name, version: "1", author: "", description: "", keyframes: [] }, null, { history: false });
        } else if (act === "save") await save();
        else if (act === "undo" && state.undo.length) {
          state.redo.push(JSON.stringify(state.anim));
          restore(state.undo.pop()); await runCheck();
        } else if (act === "redo" && state.redo.length) {
          state.undo.push(JSON.stringify(state.anim));
          restore(state.redo.pop()); await runCheck();
        } else if (act === "insert") await insertKeyframe();
        else if (act === "mirror" && state.selected >= 0) await edit("mirror", { keyframes: [state.selected] });
        else if (act === "mirror-all") await edit("mirror");
        else if (act === "invert") await edit("invert");
        else if (act === "preview") {
          const r = await api("POST", `${base()}/animation-preview`, { animation: state.anim });
          status(`preview on ${r.ghost} in the 3D view (${r.duration.toFixed(1)} s)`);
        } else if (act === "play" || act === "play-upto") {
          await save();
          const upto = act === "play-upto" ? state.selected : null;
          const r = await api("POST", `${base()}/animation-play`, { file: state.file, upto, retry_s: 15 });
          state.recordOn = false;
          status(`playing ${r.animation} (${r.keyframes} keyframes)`);
        } else if (act === "stop") {
          const r = await api("POST", `${base()}/animation-stop`);
          state.recordOn = false;
          status(`stopped${r.canceled ? " (animation canceled)" : ""}${r.record_error ? `; ${r.record_error}` : ", RECORD off"}`,
            Boolean(r.record_error));
        } else if (act === "record-on") await recordMode(true);
        else if (act === "record-off") await recordMode(false);
        else if (act === "record-kf") await recordKeyframe();
        else if (act === "rec-all" || act === "rec-none") {
          state.recordJoints = new Set(act === "rec-all" ? state.joints.map((j) => j.name) : []);
          renderJoints();
        } else if (act === "add-joint") {
          snapshot();
          const j = $('[data-role="add-joint"]').value;
          state.anim.keyframes[state.selected].goals[j] = Math.round((state.held[j] ?? 0) * 100) / 100;
          edited();
        }
      });
    });

    body.addEventListener("change", (e) => {
      const t = e.target;
      if (t.dataset.role === "ghosts") {
        state.ghosts = t.value;
        if (t.value === "off") clearGhosts(); else scheduleGhosts();
        return;
      }
      if (t.dataset.role === "upload" && t.files?.length) {
        const f = t.files[0];
        guarded(async () => {
          const name = f.name.replace(/\.json$/, "").replace(/[^A-Za-z0-9_.-]/g, "_");
          await api("PUT", `${base()}/animations/${encodeURIComponent(name)}`, { text: await f.text() });
          await listFiles();
          await open(name);
        });
        return;
      }
      const kfRow = t.closest("tr[data-kf]");
      if (kfRow && t.dataset.field) {
        snapshot();
        const kf = state.anim.keyframes[+kfRow.dataset.kf];
        if (t.dataset.field === "name") kf.name = t.value || undefined;
        else kf[t.dataset.field] = Math.max(0, Number(t.value) || 0);
        edited();
        return;
      }
      const detailRow = t.closest("[data-role=detail] tr[data-joint]");
      if (detailRow) {
        snapshot();
        const kf = state.anim.keyframes[state.selected];
        const j = detailRow.dataset.joint;
        if (t.dataset.goal !== undefined) {
          const v = t.value.trim() === "" ? NaN : Number(t.value);
          if (!Number.isFinite(v)) { state.undo.pop(); t.value = kf.goals[j]; status(`${j}: a goal is a number of degrees`, true); return; }
          kf.goals[j] = v;
        }
        if (t.dataset.torque !== undefined) {
          kf.torque = kf.torque || {};
          if (t.value === "") delete kf.torque[j]; else kf.torque[j] = Number(t.value);
        }
        edited();
        return;
      }
      const jointRow = t.closest("[data-role=joints] tr[data-joint]");
      if (jointRow) {
        const j = jointRow.dataset.joint;
        if (t.dataset.rec !== undefined) { if (t.checked) state.recordJoints.add(j); else state.recordJoints.delete(j); }
        if (t.dataset.limp !== undefined) { if (t.checked) state.limp.add(j); else state.limp.delete(j); sendGoals(true); }
        if (t.dataset.held !== undefined) {
          state.held[j] = Number(t.value);
          jointRow.querySelector("[data-slider]").value = t.value;
          sendGoals(true);
        }
      }
      if (t.dataset.role === "name" && state.anim) { snapshot(); state.anim.name = t.value; edited(); }
    });
    body.addEventListener("input", (e) => {
      const t = e.target;
      if (t.dataset.slider === undefined) return;
      const row = t.closest("tr[data-joint]");
      state.held[row.dataset.joint] = Number(t.value);
      row.querySelector("[data-held]").value = Number(t.value).toFixed(1);
      sendGoals();
    });
    const resend = setInterval(() => { if (state.recordOn && state.robot) sendGoals(); }, RESEND_MS);
    const leave = () => clearGhosts({ leaving: true });
    window.addEventListener("pagehide", leave);
    render();
    return {
      destroy() {
        picker.off(); clearInterval(resend); if (pending) clearTimeout(pending); if (ghostTimer) clearTimeout(ghostTimer);
        state.ghosts = "off"; window.removeEventListener("pagehide", leave); clearGhosts();
      },
    };
  },
};
