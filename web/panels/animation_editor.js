// Animation editor and recorder: open/upload a Bit-Bots animation or start one from the robot's pose, edit keyframes
// (structure edits run server-side through wire.animation.editing), record poses from the robot in RECORD, send the
// robot to a keyframe, preview in 3D, play (the version shown, saved or not), stop, save (only when asked).
// Work is never lost silently: a dirty marker, a warning before the page goes, and the unsaved animation kept in
// localStorage until it is saved. Goals stay inside the URDF's joint limits unless the lab overrides them.
// One editor object holds the panel's state; each function below renders one part or handles one user action.

import { expose } from "../test_hooks.js";
import { KEYS, getJSON, remove, setJSON } from "../settings.js";
import { History, replaceCommand } from "../models/history.js";
import { api, labToolOff, robotPath, robotPicker } from "../lab_api.js";
import { esc, statusLine } from "../dom.js";

const SEND_EVERY_MS = 100; // record goals while a slider is dragged
const RESEND_MS = 300; // in RECORD the held pose is sent again and again: a lost message costs nothing
const GHOSTS_AFTER_MS = 150; // keyframe ghosts follow edits and the selection, at most this often
const PLAY_POLL_MS = 250; // how often a play's progress is asked for
const DRAFT_KEY = KEYS.animDraft; // + robot: the unsaved animation, kept until saved or discarded
// A Dynamixel MX/XM servo resolves 4096 positions per turn, 0.088 deg: goals are kept and shown to a tenth of a
// degree, the finest step a person reads that the servo still tells apart, so a field never reads 90.000210459 (the
// URDF's limit of 1.5708 rad) and a typed -30 stays -30.
export const SERVO_STEP_DEG = 0.1;

// The panel's markup; rows and the keyframe detail are rendered into its tbody and div below.
const LAYOUT = `<div class="anim-controls" data-role="controls">
      <div class="lab-bar">
        <label>robot <select data-role="robot"></select></label>
        <select data-role="files" title="animation files in the robot's animation folder"></select>
        <button data-act="open">open</button>
        <label class="button file-button" title="upload a Bit-Bots JSON file">upload…<input type="file" data-role="upload"
          class="visually-hidden" accept=".json,application/json"></label>
        <input data-role="new-name" placeholder="new name" size="10"><button data-act="new"
          title="a new animation whose first keyframe is the robot's current pose">new from robot pose</button>
      </div>
      <div class="lab-bar">
        <label>file <input data-role="file" size="12"></label>
        <label>name <input data-role="name" size="12"></label>
        <label>author <input data-role="author" size="8"></label>
        <button data-act="save">save</button><span class="anim-dirty" data-role="dirty"></span>
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
        <button data-act="goto" title="RECORD, and the robot moves to the selected keyframe's pose (then edit it with
          the sliders and record)">go to keyframe</button>
        <button data-act="play" title="play on the robot as shown here (saved or not; nothing is saved)">▶ play</button>
        <button data-act="play-upto" title="play up to the selected keyframe (nothing is saved)">▶ to selected</button>
        <button data-act="stop" class="stop" title="cancel the animation and leave RECORD">■ STOP</button>
        <label title="lab only: save and play goals outside the URDF joint limits all the same (the robot's servo
          node still clamps them)"><input type="checkbox" data-role="override"> override limits</label>
        <span class="lab-status" data-role="status" role="status"></span>
      </div>
      </div>
      <ul class="anim-warnings" data-role="warnings"></ul>
      <div class="kf-timeline" data-role="timeline" title="keyframes in time (duration, then pause hatched): click to
        select, drag to reorder"></div>
      <table class="grid-table keyframes"><thead><tr><th>#</th><th>name</th><th>duration s</th><th>pause s</th>
        <th>joints</th><th></th></tr></thead><tbody data-role="keyframes"></tbody></table>
      <div data-role="detail" class="kf-detail"></div>
      <details class="record" data-role="record-box" open><summary>record from the robot</summary>
        <div class="lab-bar">
          <button data-act="record-on">RECORD on</button><button data-act="record-off">RECORD off</button>
          <button data-act="record-kf" title="insert the robot's current pose after the selected keyframe">record keyframe</button>
          <button data-act="record-update" title="the robot's current pose into the selected keyframe">update keyframe</button>
          <button data-act="rec-all">record all joints</button><button data-act="rec-none">none</button>
        </div>
        <table class="grid-table joint-groups" title="a group of joints at once, as in RecordUI"><thead><tr>
          <th>group</th><th>rec</th><th>limp</th><th></th></tr></thead><tbody data-role="groups"></tbody></table>
        <table class="grid-table"><thead><tr><th>joint</th><th>rec</th><th>limp</th><th>goal (deg)</th></tr></thead>
          <tbody data-role="joints"></tbody></table>
      </details>`;

function torqueLabel(v) { return v === undefined ? "" : v >= 0.5 ? "on" : "off"; }

export default {
  id: "animation",
  title: "Animation editor",
  size: [2, 4],
  create(body, ctx) {
    if (labToolOff(body, ctx.config)) return {};
    body.innerHTML = LAYOUT;
    const ed = newEditor(body, ctx);
    expose("animEditor", ed.state);
    ed.picker = robotPicker(ed.$('[data-role="robot"]'), ctx, (robot) => chooseRobot(ed, robot));
    ed.state.recordKeyframe = () => guarded(ed, () => recordKeyframe(ed));
    body.addEventListener("click", (e) => onClick(ed, e));
    body.addEventListener("change", (e) => onChange(ed, e));
    body.addEventListener("input", (e) => onSliderInput(ed, e));
    body.addEventListener("dragstart", (e) => onTimelineDrag(ed, e));
    body.addEventListener("pointerdown", (e) => startResize(ed, e));
    body.addEventListener("dragover", (e) => { if (e.target.closest("[data-tl]")) e.preventDefault(); });
    body.addEventListener("drop", (e) => onTimelineDrop(ed, e));
    ed.resend = setInterval(() => { if (ed.state.recordOn && ed.state.robot) sendGoals(ed); }, RESEND_MS);
    ed.leave = () => clearGhosts(ed, { leaving: true });
    window.addEventListener("pagehide", ed.leave);
    ed.warnLeaving = (e) => { if (isDirty(ed.state)) { e.preventDefault(); e.returnValue = ""; } };
    window.addEventListener("beforeunload", ed.warnLeaving);
    render(ed);
    return { destroy() { closeEditor(ed); } };
  },
};

/** The editor: its state (window.pitchside.animEditor, for tests), its elements, timers and requests under way. */
function newEditor(body, ctx) {
  const $ = (sel) => body.querySelector(sel);
  const state = {
    robot: "", file: "", anim: null, selected: -1, history: new History(), check: null, joints: [],
    held: {}, limp: new Set(), recordJoints: new Set(), recordOn: false, lastError: "", saved: 0,
    notes: {}, // "goal|<keyframe>|joint" or "held|joint" -> a limit message shown beside that joint
    ghosts: "off", ghostsShown: 0, ghostsFor: "",
    savedText: null, // the animation as last opened or saved (JSON): anything else is unsaved
    play: null, // the play under way or last ended: {name, status, percent, message}
  };
  return {
    body, ctx, $, state, picker: null, resend: 0, leave: null,
    before: null, // the animation (JSON) when an edit in place began: the start of its undo step
    status: statusLine($('[data-role="status"]'), (text) => { state.lastError = text; }),
    ghost: { timer: null, busy: false, again: false }, // keyframe ghosts, see sendGhosts
    goals: { lastSent: 0, pending: null, inFlight: false, again: false }, // record goals, see sendGoals
    playRun: 0, // each play counts up: an older play's progress stops being followed
  };
}

/** The editor closed: its timers stop, and the ghosts it showed leave the 3D view. */
function closeEditor(ed) {
  ed.picker.off(); clearInterval(ed.resend); if (ed.goals.pending) clearTimeout(ed.goals.pending);
  if (ed.ghost.timer) clearTimeout(ed.ghost.timer);
  ed.state.ghosts = "off"; window.removeEventListener("pagehide", ed.leave); clearGhosts(ed);
  window.removeEventListener("beforeunload", ed.warnLeaving); ed.playRun++;
}

/** The robot's part of every request path. */
function base(ed) { return robotPath(ed.state.robot); }

/** Runs a user action: a failure (the server's reason) shows in the status line rather than being lost. */
async function guarded(ed, fn) {
  try { await fn(); } catch (err) { ed.status(err.message, true); }
}

/** Another robot chosen: the old one's ghosts go, the new one's files and joints are read, and an animation left
 * unsaved on this robot (the page reloaded, the panel closed) comes back. */
function chooseRobot(ed, robot) {
  clearGhosts(ed);
  ed.state.robot = robot;
  guarded(ed, async () => { await loadJoints(ed); restoreDraft(ed); await listFiles(ed); });
  scheduleGhosts(ed);
}

/** The animation files in the robot's folder, into the file menu (a broken file says so). */
async function listFiles(ed) {
  const { state, $ } = ed;
  if (!state.robot) return;
  const list = await api("GET", `${base(ed)}/animations`);
  state.files = list.animations.map((a) => a.file);
  $('[data-role="files"]').innerHTML = list.animations.map((a) => `<option value="${esc(a.file)}">${esc(a.file)}${
    a.error ? " (broken)" : ""}</option>`).join("");
  state.folder = list.folder;
  showEdited(ed);
}

/** The file menu says what is being edited: its file, or a new animation that is no file yet (never the file opened
 * before it). The "open" button opens the file chosen in it. */
function showEdited(ed) {
  const { state, $ } = ed;
  const select = $('[data-role="files"]');
  select.querySelector("option[data-editing]")?.remove();
  if (!state.anim) return;
  if ((state.files ?? []).includes(state.file)) { select.value = state.file; return; }
  const option = new Option(`${state.file || state.anim.name} (new, not saved yet)`, "");
  option.dataset.editing = "";
  select.prepend(option);
  select.value = "";
}

/** The robot's joints and limits, for the record table; every joint is recorded until the user says otherwise. */
async function loadJoints(ed) {
  const { state } = ed;
  if (!state.robot) return;
  state.joints = (await api("GET", `${base(ed)}/animations/joints`)).joints;
  if (!state.recordJoints.size) state.joints.forEach((j) => state.recordJoints.add(j.name));
  try { holdMeasuredPose(ed, await measuredPose(ed)); } catch { /* no joint_states yet: the sliders start at 0 */ }
  renderJoints(ed);
}

/** The robot's measured pose (deg per joint), from the hub's newest joint_states. */
async function measuredPose(ed) { return (await api("GET", `${base(ed)}/record/pose`)).positions; }

/** The record table starts where the robot is, not at 0, so RECORD on holds the robot still. */
function holdMeasuredPose(ed, pose) {
  const { state } = ed;
  state.held = {};
  for (const j of state.joints) if (j.name in pose) state.held[j.name] = inLimits(ed, j.name, pose[j.name]).value;
}

// -- joint limits and order ------------------------------------------------------------------------

/** A goal (deg) at the nearest step the editor keeps (SERVO_STEP_DEG). */
export function servoDeg(deg) {
  return Number((Math.round(deg / SERVO_STEP_DEG) * SERVO_STEP_DEG).toFixed(1));
}

/** A goal as the fields show it: one decimal at most, no trailing zero (44.6, -90, 12.3). */
export function fmtDeg(deg) {
  return String(Number(Number(deg).toFixed(1)));
}

/** A goal (deg) at a servo step inside the joint's URDF limits (the step nearest inside a limit that falls between
 * two); clamped says it had to be moved. */
function inLimits(ed, joint, deg) {
  const j = ed.state.joints.find((x) => x.name === joint);
  const rounded = servoDeg(deg);
  if (!j) return { value: rounded, clamped: false };
  let value = servoDeg(Math.min(Math.max(deg, j.lower), j.upper));
  if (value > j.upper) value = servoDeg(value - SERVO_STEP_DEG);
  if (value < j.lower) value = servoDeg(value + SERVO_STEP_DEG);
  return { value, clamped: deg < j.lower - 1e-9 || deg > j.upper + 1e-9, j };
}

/** The word on a clamped goal: what was typed, the limits, what was set instead. */
function clampedText(joint, typed, limit) {
  return `${joint}: ${typed} deg is outside its limits [${limit.j.lower.toFixed(1)}, ${limit.j.upper.toFixed(1)}] ` +
    `deg: set to ${fmtDeg(limit.value)}`;
}

/** A note beside a joint of the record table: said where the user looks, kept until that joint is set again. */
function noteJoint(ed, where, joint, text) {
  const key = `${where}|${joint}`;
  if (text) ed.state.notes[key] = text; else delete ed.state.notes[key];
  const el = ed.$(`[data-role="joints"] tr[data-joint="${CSS.escape(joint)}"] [data-note]`);
  if (el) el.textContent = text;
}

/** Goals and torques of every keyframe in the robot's joint order (the URDF's), whatever the file or an edit did;
 * joints the robot lacks come last. Only the key order changes, so nothing becomes unsaved by it. */
function inRobotOrder(ed, anim) {
  const rank = new Map(ed.state.joints.map((j, i) => [j.name, i]));
  if (!anim || !rank.size) return;
  const order = (table) => Object.fromEntries(Object.entries(table).sort(([a], [b]) =>
    (rank.get(a) ?? rank.size) - (rank.get(b) ?? rank.size)));
  for (const kf of anim.keyframes) {
    kf.goals = order(kf.goals);
    if (kf.torque) kf.torque = order(kf.torque);
  }
}

// -- unsaved work ----------------------------------------------------------------------------------

/** The animation differs from the one last opened or saved (a new one is unsaved until saved). */
function isDirty(state) { return Boolean(state.anim) && JSON.stringify(state.anim) !== state.savedText; }

/** The animation as it is now counts as saved. */
function markSaved(ed) {
  inRobotOrder(ed, ed.state.anim);
  ed.state.savedText = JSON.stringify(ed.state.anim);
}

/** The unsaved animation into the browser's storage (per robot, web/settings.js), so neither a reload nor a closed panel loses it. */
function keepDraft(ed) {
  const { state } = ed;
  if (!state.robot || !state.anim) return; // nothing shown yet: a kept draft waits for restoreDraft
  // storage full or off: the beforeunload warning still guards the work
  if (isDirty(state)) {
    setJSON(DRAFT_KEY + state.robot, { file: state.file, anim: state.anim, savedText: state.savedText,
      selected: state.selected }); // where the user was
  } else remove(DRAFT_KEY + state.robot);
}

/** The draft kept for this robot, back in the editor (only when the editor holds nothing yet). */
function restoreDraft(ed) {
  const { state } = ed;
  if (state.anim) return;
  const draft = getJSON(DRAFT_KEY + state.robot);
  if (!draft?.anim?.keyframes) return;
  state.file = draft.file ?? ""; state.savedText = draft.savedText ?? null;
  const n = draft.anim.keyframes.length;
  state.history.clear();
  state.selected = Number.isInteger(draft.selected) && draft.selected < n ? Math.max(draft.selected, n ? 0 : -1)
    : n ? 0 : -1; // the keyframe the user was on
  setAnimation(ed, draft.anim, null, { history: false });
  ed.$(`[data-role="keyframes"] tr[data-kf="${state.selected}"]`)?.scrollIntoView({ block: "nearest" });
  ed.status(`restored unsaved changes to ${state.file || draft.anim.name} at keyframe ${state.selected}: save them, ` +
    "or open another file");
}

/** Before the animation shown is replaced: true if it is saved, or the user agrees to lose its changes. */
function mayDiscard(ed, doing) {
  const { state } = ed;
  if (!isDirty(state)) return true;
  return window.confirm(`${state.file || state.anim.name} has unsaved changes. Discard them and ${doing}?`);
}

// -- the animation and its history -----------------------------------------------------------------

/** A new animation (an edit's reply, a file opened): one undo step from the old one unless told not to. */
function setAnimation(ed, anim, check, { history = true } = {}) {
  const { state } = ed;
  if (history && state.anim) {
    state.history.record(replaceCommand("edit", JSON.stringify(state.anim), JSON.stringify(anim),
      (text) => restore(ed, text)));
  }
  state.anim = anim;
  if (state.selected >= anim.keyframes.length) state.selected = anim.keyframes.length - 1;
  if (check) state.check = check;
  render(ed);
  if (!check) guarded(ed, () => runCheck(ed));
}

/** The server's errors and warnings for the animation as it is now. */
async function runCheck(ed) {
  ed.state.check = await api("POST", `${base(ed)}/animation-check`, { animation: ed.state.anim });
  renderWarnings(ed);
}

/** A field changed in place (after snapshot): one undo step from the snapshot to now; redraw and check again. */
function edited(ed) {
  const { state } = ed;
  if (ed.before !== null && state.anim) {
    state.history.record(replaceCommand("edit", ed.before, JSON.stringify(state.anim), (text) => restore(ed, text)));
  }
  ed.before = null;
  render(ed);
  guarded(ed, () => runCheck(ed));
}

/** The animation as it is, kept as the start of the undo step an edit in place makes (edited ends it). */
function snapshot(ed) { ed.before = ed.state.anim ? JSON.stringify(ed.state.anim) : null; }

/** An undo/redo step: the animation as it was, the selection kept inside it. */
function restore(ed, text) {
  const { state } = ed;
  state.anim = JSON.parse(text);
  const n = state.anim.keyframes.length;
  state.selected = Math.min(Math.max(state.selected, n ? 0 : -1), n - 1);
  render(ed);
}

/** Undo (or redo) one step of the history; the animation it leaves is shown and checked. */
async function stepHistory(ed, back) {
  const { history } = ed.state;
  if (!(back ? history.undo() : history.redo())) return;
  const more = back ? history.done.length : history.undone.length;
  ed.status(`${back ? "undone" : "redone"} (${more} more)${isDirty(ed.state) ? "" : ": as saved"}`);
  await runCheck(ed);
}

/** The pose the animation holds at the end of keyframe k: every goal up to k, the newest per joint. */
function poseAfter(anim, k) {
  const pose = {};
  for (const kf of anim.keyframes.slice(0, k + 1)) Object.assign(pose, kf.goals);
  return pose;
}

/** A name for a new keyframe ("kf 3"), one no keyframe of the animation has: named by default, renamed in its row. */
export function newKeyframeName(anim) {
  const taken = new Set((anim?.keyframes ?? []).map((kf) => kf.name));
  let n = (anim?.keyframes ?? []).length;
  while (taken.has(`kf ${n}`)) n++;
  return `kf ${n}`;
}

/** "+ keyframe": a new keyframe after the selected one, posed where that one ends, so nothing jumps. */
async function insertKeyframe(ed) {
  const { state } = ed;
  if (!state.anim) throw new Error("open, upload or start a new animation first");
  const index = state.selected + 1;
  await edit(ed, "insert", { index, keyframe: { name: newKeyframeName(state.anim), duration: 1.0, pause: 0.0,
    goals: poseAfter(state.anim, state.selected), torque: {} } });
  state.selected = index;
  render(ed);
  ed.status(`inserted keyframe ${index} (posed where keyframe ${index - 1} ends)`);
}

/** A structure edit, done server-side (the one implementation of editing); its reply is the new animation. */
async function edit(ed, op, extra = {}) {
  const reply = await api("POST", `${base(ed)}/animation-edit`, { animation: ed.state.anim, op, ...extra });
  setAnimation(ed, reply.animation, reply.check);
  return reply;
}

/** Opens a file of the robot's folder: a fresh history, the first keyframe selected. */
async function openFile(ed, file, { asked = false } = {}) {
  const { state } = ed;
  if (!file) throw new Error("no animation file chosen");
  if (!asked && !mayDiscard(ed, `open ${file}`)) { ed.status(`kept the unsaved changes (${file} not opened)`); return; }
  const reply = await api("GET", `${base(ed)}/animations/${encodeURIComponent(file)}`);
  state.file = reply.file;
  state.history.clear(); state.selected = reply.animation.keyframes.length ? 0 : -1;
  state.anim = null;
  inRobotOrder(ed, reply.animation);
  state.savedText = JSON.stringify(reply.animation);
  setAnimation(ed, reply.animation, reply.check, { history: false });
  ed.status(`opened ${reply.file}`);
}

/** "new from robot pose": an animation named from the new-name box whose first keyframe is the robot's measured pose
 * (every joint, inside its limits), the sliders holding it too; unsaved until saved. Without joint_states: empty. */
async function startNew(ed) {
  const { state } = ed;
  const name = ed.$('[data-role="new-name"]').value.trim() || "new_animation";
  if (!mayDiscard(ed, `start ${name}`)) { ed.status(`kept the unsaved changes (${name} not started)`); return; }
  let pose = null;
  let why = "";
  try { pose = await measuredPose(ed); } catch (err) { why = err.message; }
  const keyframes = [];
  if (pose) {
    holdMeasuredPose(ed, pose);
    renderJoints(ed);
    keyframes.push({ name: "start", duration: 1.0, pause: 0.0, goals: { ...state.held }, torque: {} });
  }
  state.file = name; state.history.clear(); state.selected = keyframes.length - 1;
  state.anim = null; state.savedText = null;
  setAnimation(ed, { name, version: "1", author: "", description: "", keyframes }, null, { history: false });
  ed.status(pose ? `new ${name}: keyframe 0 is the robot's pose (${Object.keys(keyframes[0].goals).length} joints), ` +
    "not saved yet" : `new ${name}, empty: no pose from the robot (${why})`, !pose);
}

/** Uploads a Bit-Bots JSON file into the robot's folder (under a safe name) and opens it. */
async function upload(ed, f) {
  const name = f.name.replace(/\.json$/, "").replace(/[^A-Za-z0-9_.-]/g, "_");
  if (!mayDiscard(ed, `upload ${name}`)) { ed.status(`kept the unsaved changes (${name} not uploaded)`); return; }
  await api("PUT", `${base(ed)}/animations/${encodeURIComponent(name)}`, { text: await f.text() });
  await listFiles(ed);
  await openFile(ed, name, { asked: true });
}

/** "save" (the only thing that writes the user's file): under the file box's name (the animation's name if empty);
 * goals outside the joint limits are refused unless "override limits" is ticked. The server's copy is shown. */
async function saveFile(ed) {
  const { state, $ } = ed;
  if (!state.anim) throw new Error("nothing to save: open, upload or start a new animation first");
  syncMeta(ed);
  const file = $('[data-role="file"]').value.trim() || state.anim.name;
  const reply = await api("PUT", `${base(ed)}/animations/${encodeURIComponent(file)}`,
    { animation: state.anim, author: $('[data-role="author"]').value || state.anim.author || "",
      override_limits: overridden(ed) });
  state.file = reply.file;
  state.anim = reply.animation;
  state.check = reply.check;
  state.saved++;
  markSaved(ed);
  render(ed);
  ed.status(`saved ${reply.path}${reply.check.out_of_limits?.length ? " (limits overridden)" : ""}`);
  await listFiles(ed);
}

/** "override limits" ticked: save and play goals outside the joint limits all the same. */
function overridden(ed) { return ed.$('[data-role="override"]').checked; }

/** The name box into the animation, in case it was typed but not yet committed by a change event. */
function syncMeta(ed) {
  if (!ed.state.anim) return;
  const name = ed.$('[data-role="name"]').value.trim();
  if (name) ed.state.anim.name = name;
}

// -- on the robot and in 3D -----------------------------------------------------------------------

/** "preview 3D": a ghost robot plays the animation in the 3D view; the robot does not move. */
async function preview(ed) {
  const r = await api("POST", `${base(ed)}/animation-preview`, { animation: ed.state.anim });
  ed.status(`preview on ${r.ghost} in the 3D view (${r.duration.toFixed(1)} s)`);
}

/** "▶ play" (all, or up to the selected keyframe): the robot plays the animation as shown here, saved or not;
 * nothing is saved. Its progress follows in the status line until done or failed. */
async function play(ed, toSelected) {
  const { state } = ed;
  if (!state.anim?.keyframes.length) throw new Error("nothing to play: the animation has no keyframes");
  syncMeta(ed);
  const upto = toSelected ? state.selected : null;
  const name = state.anim.name + (isDirty(state) ? " (unsaved version)" : "");
  const run = ++ed.playRun;
  const r = await api("POST", `${base(ed)}/animation-play`, { draft: state.anim, upto, retry_s: 15,
    override_limits: overridden(ed) });
  state.recordOn = false;
  state.play = { name, status: null, percent: 0, message: "" };
  ed.status(`playing ${name}: ${r.keyframes} keyframes`);
  followPlay(ed, run);
}

/** A play's progress in the status line (percent done), then how it ended: done, or failed and why. */
async function followPlay(ed, run) {
  const { state } = ed;
  while (run === ed.playRun) {
    await new Promise((resolve) => setTimeout(resolve, PLAY_POLL_MS));
    if (run !== ed.playRun) return;
    let s;
    try { s = await api("GET", `${base(ed)}/animation-play`); } catch (err) {
      ed.status(`${state.play.name}: no word on the play (${err.message})`, true);
      return;
    }
    Object.assign(state.play, { status: s.status ?? null, percent: s.percent_done ?? 0, message: s.message ?? "" });
    if (s.playing) { ed.status(`playing ${state.play.name}: ${Math.round(state.play.percent)} %`); continue; }
    if (s.succeeded) ed.status(`played ${state.play.name}: done`);
    else ed.status(`${state.play.name}: failed (${(s.status ?? "no result").toLowerCase()}${
      s.message ? `: ${s.message}` : ""})`, true);
    return;
  }
}

/** "■ STOP": the animation is canceled and RECORD left; a failure to leave RECORD is shown as one. */
async function stopOnRobot(ed) {
  ed.playRun++; // the stop's word replaces the play's progress
  const r = await api("POST", `${base(ed)}/animation-stop`);
  ed.state.recordOn = false;
  ed.status(`stopped${r.canceled ? " (animation canceled)" : ""}${r.record_error ? `; ${r.record_error}` : ", RECORD off"}`,
    Boolean(r.record_error));
}

// -- keyframe ghosts in 3D -------------------------------------------------------------------------
// one request at a time, the newest state wins; the server replaces the ghosts it showed before

/** The keyframes to show as ghosts: all, or the selected one and its neighbours. */
function ghostKeyframes(state) {
  const n = state.anim?.keyframes.length ?? 0;
  if (state.ghosts === "all") return [...Array(n).keys()];
  const s = state.selected;
  return s < 0 ? [] : [s - 1, s, s + 1].filter((k) => k >= 0 && k < n);
}

/** The ghosts menu changed: off removes them, anything else shows them. */
function setGhosts(ed, value) {
  ed.state.ghosts = value;
  if (value === "off") clearGhosts(ed); else scheduleGhosts(ed);
}

/** Ghosts follow edits and the selection, at most every GHOSTS_AFTER_MS. */
function scheduleGhosts(ed) {
  if (ed.state.ghosts === "off" || !ed.state.robot) return;
  if (!ed.ghost.timer) ed.ghost.timer = setTimeout(() => sendGhosts(ed), GHOSTS_AFTER_MS);
}

/** Sends the ghosts to the server; one request at a time, a change meanwhile sends once more afterwards. */
async function sendGhosts(ed) {
  const { state, ghost } = ed;
  ghost.timer = null;
  if (ghost.busy) { ghost.again = true; return; }
  if (state.ghosts === "off" || !state.robot) return;
  ghost.busy = true;
  const robot = state.robot;
  state.ghostsFor = robot; // from now on the server may hold ghosts of this robot: clean them up on leaving
  try {
    const animation = state.anim ?? { name: "none", keyframes: [] };
    const r = await api("POST", `${base(ed)}/animation-ghosts`, { animation, keyframes: ghostKeyframes(state),
      selected: state.selected });
    state.ghostsShown = r.keyframes.length;
    state.ghostUpdates = (state.ghostUpdates || 0) + 1;
    if (state.ghosts === "off" || state.robot !== robot) clearGhosts(ed); // switched off while under way
  } catch (err) {
    ed.status(`keyframe ghosts: ${err.message}`, true);
    state.ghosts = "off"; ed.$('[data-role="ghosts"]').value = "off";
  }
  ghost.busy = false;
  if (ghost.again) { ghost.again = false; sendGhosts(ed); }
}

/** Removes the ghosts from the 3D view (switched off, another robot, the editor closed). */
function clearGhosts(ed, { leaving = false } = {}) {
  const { state } = ed;
  if (!state.ghostsFor) return;
  const robot = state.ghostsFor;
  state.ghostsFor = ""; state.ghostsShown = 0;
  api("DELETE", `${robotPath(robot)}/animation-ghosts`, undefined, { keepalive: leaving }).catch((err) => {
    if (!leaving) ed.status(`keyframe ghosts: ${err.message}`, true);
  });
}

// -- rendering --------------------------------------------------------------------------------------

/** Everything that shows the animation: the file bar, the keyframe list, the selected keyframe, the warnings. */
function render(ed) {
  inRobotOrder(ed, ed.state.anim);
  keepDraft(ed);
  renderFileBar(ed);
  renderTimeline(ed);
  renderKeyframes(ed);
  renderDetail(ed);
  renderWarnings(ed);
  scheduleGhosts(ed);
}

/** File, name and author boxes and the undo/redo buttons; an author being typed is left alone. */
function renderFileBar(ed) {
  const { state, $ } = ed;
  const anim = state.anim;
  $('[data-role="file"]').value = state.file;
  $('[data-role="name"]').value = anim?.name ?? "";
  if (anim && document.activeElement !== $('[data-role="author"]')) $('[data-role="author"]').value = anim.author ?? "";
  $('[data-act="undo"]').disabled = !state.history.canUndo;
  $('[data-act="redo"]').disabled = !state.history.canRedo;
  showEdited(ed);
  const dirty = isDirty(state);
  $('[data-role="dirty"]').textContent = dirty ? "● unsaved" : anim ? "saved" : "";
  $('[data-role="dirty"]').classList.toggle("unsaved", dirty);
  $('[data-act="save"]').classList.toggle("unsaved", dirty);
}

/** The timeline: a block per keyframe, as wide as its share of the animation's time (its pause hatched at its end),
 * the selected one marked; blocks are dragged to reorder (Bit-Bots' RecordUI habit). */
function renderTimeline(ed) {
  const { state } = ed;
  const kfs = state.anim?.keyframes ?? [];
  const total = kfs.reduce((t, kf) => t + kf.duration + kf.pause, 0);
  const el = ed.$('[data-role="timeline"]');
  el.innerHTML = kfs.map((kf, i) => `<div class="kf-block${i === state.selected ? " selected" : ""}" data-tl="${i}"
      draggable="true" title="keyframe ${i}${kf.name ? ` (${esc(kf.name)})` : ""}: ${kf.duration} s${
      kf.pause ? ` + ${kf.pause} s pause` : ""}"><span>${i}${kf.name ? ` ${esc(kf.name)}` : ""}</span>
      <i class="kf-pause"></i><b class="kf-resize" data-resize="${i}" title="drag to change keyframe ${i}'s duration
      (${kf.duration} s)"></b></div>`).join("");
  // widths through the CSSOM: the page's Content-Security-Policy need not allow inline styles
  el.querySelectorAll("[data-tl]").forEach((block, i) => {
    const kf = kfs[i];
    const time = kf.duration + kf.pause;
    block.style.flexGrow = String(total > 0 ? time / total : 1);
    block.querySelector(".kf-pause").style.width = `${time > 0 ? (100 * kf.pause) / time : 0}%`;
  });
}

/** The keyframe list, the selected row marked; a hint while there is no animation. */
function renderKeyframes(ed) {
  const { state } = ed;
  const rows = state.anim ? state.anim.keyframes.map((kf, i) => keyframeRow(kf, i, i === state.selected)).join("") : "";
  ed.$('[data-role="keyframes"]').innerHTML = rows
    || '<tr><td colspan="6" class="empty">open, upload or start a new animation</td></tr>';
}

/** One keyframe's row: name, duration and pause edited in place, buttons to move, duplicate and delete it. */
function keyframeRow(kf, i, selected) {
  return `<tr data-kf="${i}" class="${selected ? "selected" : ""}">
        <td>${i}</td><td><input data-field="name" value="${esc(kf.name ?? "")}" size="8"></td>
        <td><input type="number" step="0.05" min="0" data-field="duration" value="${esc(kf.duration)}"></td>
        <td><input type="number" step="0.05" min="0" data-field="pause" value="${esc(kf.pause)}"></td>
        <td>${Object.keys(kf.goals).length}</td>
        <td><button data-kact="up" title="move up">↑</button><button data-kact="down" title="move down">↓</button>
          <button data-kact="duplicate" title="duplicate">dup</button><button data-kact="delete" title="delete">✕</button></td>
        </tr>`;
}

/** The server's errors and warnings about the animation: errors first, then goals outside the joint limits (no save
 * or play without "override limits"), then the other warnings. */
function renderWarnings(ed) {
  const c = ed.state.check;
  const limits = new Set(c?.out_of_limits ?? []);
  ed.$('[data-role="warnings"]').innerHTML = c ? [...c.errors.map((e) => `<li class="bad">${esc(e)}</li>`),
    ...[...limits].map((w) => `<li class="bad limit">${esc(w)} (no save or play unless "override limits")</li>`),
    ...c.warnings.filter((w) => !limits.has(w)).map((w) => `<li class="warn">${esc(w)}</li>`)].join("") : "";
}

/** The selected keyframe's goals and torques, and a menu to add a joint it does not move yet. */
function renderDetail(ed) {
  const { state } = ed;
  const kf = state.anim?.keyframes[state.selected];
  const el = ed.$('[data-role="detail"]');
  if (!kf) { el.innerHTML = ""; return; }
  const missing = state.joints.filter((j) => !(j.name in kf.goals));
  el.innerHTML = `<b>keyframe ${state.selected}</b> goals (deg) and torque
        <table class="grid-table"><tbody>${Object.entries(kf.goals).map(([j, v]) => goalRow(kf, j, v, notesOf(state, `goal|${state.selected}|`))).join("")}</tbody></table>
        ${missing.length ? `<select data-role="add-joint">${missing.map((j) => `<option>${esc(j.name)}</option>`).join("")}</select>
        <button data-act="add-joint">add joint</button>` : ""}`;
}

/** The limit notes under a prefix, by joint. */
function notesOf(state, prefix) {
  return Object.fromEntries(Object.entries(state.notes).filter(([k]) => k.startsWith(prefix))
    .map(([k, v]) => [k.slice(prefix.length), v]));
}

/** One joint of the selected keyframe: its goal, its torque (on, off, unchanged), a button to remove it. */
function goalRow(kf, j, v, notes) {
  return `<tr data-joint="${esc(j)}">
          <td>${esc(j)}</td><td><input type="number" step="${SERVO_STEP_DEG}" data-goal value="${esc(fmtDeg(v))}">
            <span class="limit-note" data-note>${esc(notes[j] ?? "")}</span></td>
          <td><select data-torque><option value="">torque unchanged</option>
            <option value="1" ${torqueLabel(kf.torque?.[j]) === "on" ? "selected" : ""}>torque on</option>
            <option value="0" ${torqueLabel(kf.torque?.[j]) === "off" ? "selected" : ""}>torque off</option></select></td>
          <td><button data-remove title="remove this joint from the keyframe">✕</button></td></tr>`;
}

/** The record table: per joint whether it is recorded, whether it is limp, and the goal it is held at. */
function renderJoints(ed) {
  const { state } = ed;
  renderGroups(ed);
  ed.$('[data-role="joints"]').innerHTML = state.joints.map((j) => `<tr data-joint="${esc(j.name)}">
        <td>${esc(j.name)}</td>
        <td><input type="checkbox" data-rec aria-label="record ${esc(j.name)}"
          ${state.recordJoints.has(j.name) ? "checked" : ""}></td>
        <td><input type="checkbox" data-limp aria-label="${esc(j.name)} limp" ${state.limp.has(j.name) ? "checked" : ""}></td>
        <td><input type="range" data-slider aria-label="${esc(j.name)} goal (slider)" min="${esc(j.lower)}"
          max="${esc(j.upper)}" step="${SERVO_STEP_DEG}" value="${esc(state.held[j.name] ?? 0)}">
          <input type="number" data-held aria-label="${esc(j.name)} goal (deg)" step="${SERVO_STEP_DEG}"
          value="${fmtDeg(state.held[j.name] ?? 0)}">
          <span class="limit-note" data-note>${esc(state.notes[`held|${j.name}`] ?? "")}</span></td></tr>`).join("");
}

// -- recording --------------------------------------------------------------------------------------
// one request in flight at a time, so goals reach the robot in the order they were made; the newest wins

/** The held pose to the robot: at once, or at most every SEND_EVERY_MS while a slider is dragged. */
function sendGoals(ed, now = false) {
  const { goals } = ed;
  if (now || performance.now() - goals.lastSent > SEND_EVERY_MS) postGoals(ed);
  else if (!goals.pending) goals.pending = setTimeout(() => postGoals(ed), SEND_EVERY_MS);
}

/** Posts the held goals of the joints that are not limp, and the limp ones; a request under way sends again after. */
async function postGoals(ed) {
  const { state, goals } = ed;
  goals.pending = null;
  if (goals.inFlight) { goals.again = true; return; }
  const positions = {};
  for (const [j, v] of Object.entries(state.held)) if (!state.limp.has(j)) positions[j] = v;
  if (!Object.keys(positions).length && !state.limp.size) return;
  goals.inFlight = true; goals.lastSent = performance.now();
  await guarded(ed, () => api("POST", `${base(ed)}/record/goals`, { positions, limp: [...state.limp] }));
  state.goalsSent = (state.goalsSent || 0) + 1;
  goals.inFlight = false;
  if (goals.again) { goals.again = false; postGoals(ed); }
}

/** RECORD on or off; on holds the pose the robot is in, so nothing jumps when RECORD starts. */
async function recordMode(ed, on) {
  const { state } = ed;
  state.recordOn = false;
  if (on) {
    holdMeasuredPose(ed, await measuredPose(ed));
    renderJoints(ed);
  }
  await api("POST", `${base(ed)}/record`, { on });
  state.recordOn = on;
  ed.status(on ? "RECORD: move the sliders (or the limp joints by hand), then record keyframes" : "RECORD off");
}

/** The robot's pose now, the recorded joints only, inside their limits (deg). */
async function recordedPose(ed) {
  const { state } = ed;
  const pose = await measuredPose(ed);
  const goals = {};
  for (const j of state.joints) {
    if (state.recordJoints.has(j.name) && j.name in pose) goals[j.name] = inLimits(ed, j.name, pose[j.name]).value;
  }
  return goals;
}

/** "record keyframe": the robot's pose now (the recorded joints) as a new keyframe after the selected one. */
async function recordKeyframe(ed) {
  const { state } = ed;
  const goals = await recordedPose(ed);
  if (!state.anim) {
    state.anim = { name: ed.$('[data-role="new-name"]').value || "recorded", keyframes: [] };
    state.savedText = null;
  }
  const index = state.selected + 1;
  await edit(ed, "insert", { index, keyframe: { name: newKeyframeName(state.anim), duration: 1.0, pause: 0.0, goals,
    torque: {} } });
  state.selected = index;
  render(ed);
  ed.status(`recorded keyframe ${index} (${Object.keys(goals).length} joints)`);
}

/** "update keyframe": the robot's pose now (the recorded joints) into the selected keyframe, as RecordUI does after
 * "go to keyframe" and a few slider moves. */
async function updateKeyframe(ed) {
  const { state } = ed;
  const kf = state.anim?.keyframes[state.selected];
  if (!kf) throw new Error("select a keyframe to update");
  const goals = await recordedPose(ed);
  snapshot(ed);
  Object.assign(kf.goals, goals);
  edited(ed);
  ed.status(`updated keyframe ${state.selected} from the robot (${Object.keys(goals).length} joints)`);
}

/** "go to keyframe": RECORD on (through the HCM) and the robot held at the pose the selected keyframe ends in, the
 * sliders showing it; edit with the sliders, then "update keyframe" or "record keyframe". */
async function goToKeyframe(ed) {
  const { state } = ed;
  const k = state.selected;
  if (!state.anim?.keyframes[k]) throw new Error("select a keyframe to go to");
  if (!state.recordOn) await recordMode(ed, true);
  const clamped = [];
  for (const [j, deg] of Object.entries(poseAfter(state.anim, k))) {
    const limit = inLimits(ed, j, deg);
    if (limit.clamped) clamped.push(j);
    state.held[j] = limit.value;
    state.limp.delete(j); // a limp joint would not move there
  }
  renderJoints(ed);
  sendGoals(ed, true);
  ed.status(`robot going to keyframe ${k} (RECORD)${clamped.length ? `; held inside the limits: ${clamped.join(", ")}`
    : ""}: move the sliders, then "update keyframe" or "record keyframe"`);
}

// -- joint groups: head, arms, legs, by the joints' names (RecordUI's groups) -------------------------------

export const GROUPS = [["head", "head"], ["left arm", "L-arm"], ["right arm", "R-arm"], ["left leg", "L-leg"],
  ["right leg", "R-leg"]];

/** The group a joint belongs to, from its name (HeadPan; LShoulderPitch, LElbow; RHipYaw, RKnee, RAnkleRoll ...);
 * "" for a joint of no group. */
export function jointGroup(name) {
  if (/^head/i.test(name)) return "head";
  const side = /^(?:L|l|left|Left)(?=[A-Z_])/.test(name) ? "L" : /^(?:R|r|right|Right)(?=[A-Z_])/.test(name) ? "R" : "";
  if (!side) return "";
  if (/shoulder|elbow|arm|wrist|hand/i.test(name)) return `${side}-arm`;
  if (/hip|knee|ankle|foot|leg/i.test(name)) return `${side}-leg`;
  return "";
}

/** The joint groups' table: per group whether all its joints are recorded / limp, and "pose → keyframe". */
function renderGroups(ed) {
  const { state } = ed;
  const rows = GROUPS.map(([label, id]) => {
    const joints = state.joints.filter((j) => jointGroup(j.name) === id).map((j) => j.name);
    if (!joints.length) return "";
    const all = (set) => joints.every((j) => set.has(j));
    return `<tr data-group="${esc(id)}" title="${esc(joints.join(", "))}"><td>${esc(label)}</td>
      <td><input type="checkbox" data-group-rec aria-label="record the ${esc(label)}" ${all(state.recordJoints) ? "checked" : ""}></td>
      <td><input type="checkbox" data-group-limp aria-label="${esc(label)} limp" ${all(state.limp) ? "checked" : ""}></td>
      <td><button data-group-copy title="the robot's pose of the ${esc(label)} into the selected keyframe">pose → keyframe</button></td></tr>`;
  }).join("");
  ed.$('[data-role="groups"]').innerHTML = rows;
}

/** A group's rec or limp ticked: every joint of it at once (limp is sent to the robot at once). */
function editGroup(ed, t, id) {
  const { state } = ed;
  const joints = state.joints.filter((j) => jointGroup(j.name) === id).map((j) => j.name);
  const set = t.dataset.groupRec !== undefined ? state.recordJoints : state.limp;
  for (const j of joints) { if (t.checked) set.add(j); else set.delete(j); }
  renderJoints(ed);
  if (t.dataset.groupLimp !== undefined) sendGoals(ed, true);
  ed.status(`${id}: ${joints.length} joints ${t.dataset.groupRec !== undefined ? (t.checked ? "recorded" : "not recorded")
    : (t.checked ? "limp" : "held")}`);
}

/** "pose → keyframe": the robot's pose of one group's joints into the selected keyframe (the other joints stay). */
async function copyGroup(ed, id) {
  const { state } = ed;
  const kf = state.anim?.keyframes[state.selected];
  if (!kf) throw new Error("select a keyframe to copy the pose into");
  const pose = await measuredPose(ed);
  const joints = state.joints.filter((j) => jointGroup(j.name) === id && j.name in pose).map((j) => j.name);
  if (!joints.length) throw new Error(`no pose of the ${id} from the robot`);
  snapshot(ed);
  for (const j of joints) kf.goals[j] = inLimits(ed, j, pose[j]).value;
  edited(ed);
  ed.status(`keyframe ${state.selected}: the ${id}'s pose from the robot (${joints.length} joints)`);
}

/** "record all joints" / "none". */
function chooseRecordJoints(ed, all) {
  ed.state.recordJoints = new Set(all ? ed.state.joints.map((j) => j.name) : []);
  renderJoints(ed);
}

// -- events -----------------------------------------------------------------------------------------

/** The bars' buttons by their data-act, each a user action whose failure shows in the status line. */
const ACTIONS = {
  open: (ed) => openFile(ed, ed.$('[data-role="files"]').value),
  new: startNew,
  save: saveFile,
  undo: (ed) => stepHistory(ed, true),
  redo: (ed) => stepHistory(ed, false),
  insert: insertKeyframe,
  mirror: async (ed) => {
    const k = ed.state.selected;
    if (k < 0) throw new Error("select a keyframe to mirror");
    await edit(ed, "mirror", { keyframes: [k] });
    ed.status(`mirrored keyframe ${k} (left and right swapped)`);
  },
  "mirror-all": async (ed) => { await edit(ed, "mirror"); ed.status("mirrored every keyframe"); },
  invert: async (ed) => { await edit(ed, "invert"); ed.status("inverted: the animation plays backwards"); },
  preview,
  goto: goToKeyframe,
  play: (ed) => play(ed, false),
  "play-upto": (ed) => play(ed, true),
  stop: stopOnRobot,
  "record-on": (ed) => recordMode(ed, true),
  "record-off": (ed) => recordMode(ed, false),
  "record-kf": recordKeyframe,
  "record-update": updateKeyframe,
  "rec-all": (ed) => chooseRecordJoints(ed, true),
  "rec-none": (ed) => chooseRecordJoints(ed, false),
  "add-joint": addGoal,
};

/** Clicks: a keyframe row selects it, its buttons edit it, a goal's ✕ removes it, the bars' buttons act. */
function onClick(ed, e) {
  const act = e.target.dataset?.act;
  const kact = e.target.dataset?.kact;
  const row = e.target.closest("tr[data-kf]");
  if (row && !kact && e.target.tagName !== "INPUT") { ed.state.selected = +row.dataset.kf; render(ed); }
  const block = e.target.closest("[data-tl]");
  if (block) { ed.state.selected = +block.dataset.tl; render(ed); }
  if (kact) { guarded(ed, () => keyframeAction(ed, kact, +row.dataset.kf)); return; }
  if (e.target.dataset?.groupCopy !== undefined) {
    const id = e.target.closest("tr[data-group]").dataset.group;
    guarded(ed, () => copyGroup(ed, id));
    return;
  }
  if (e.target.dataset?.remove !== undefined && e.target.closest("[data-role=detail]")) {
    removeGoal(ed, e.target.closest("tr").dataset.joint);
    return;
  }
  if (act && Object.hasOwn(ACTIONS, act)) guarded(ed, () => ACTIONS[act](ed));
}

const DURATION_STEP_S = 0.05;
const MIN_DURATION_S = 0.05;

/** A keyframe's right edge on the timeline dragged: its duration follows the pointer (at the timeline's scale when
 * the drag began, in steps of 0.05 s), shown as it goes and written once, on release, as one undo step. */
function startResize(ed, e) {
  const handle = e.target.closest?.("[data-resize]");
  if (!handle || !ed.state.anim) return;
  e.preventDefault(); // not the block's drag to reorder
  e.stopPropagation();
  const i = +handle.dataset.resize;
  const kfs = ed.state.anim.keyframes;
  const total = kfs.reduce((t, kf) => t + kf.duration + kf.pause, 0);
  const timeline = ed.$('[data-role="timeline"]');
  const perPx = total / Math.max(timeline.getBoundingClientRect().width, 1); // s per px
  const x0 = e.clientX, d0 = kfs[i].duration;
  const durationAt = (x) => Math.max(MIN_DURATION_S,
    Math.round((d0 + (x - x0) * perPx) / DURATION_STEP_S) * DURATION_STEP_S);
  handle.setPointerCapture(e.pointerId);
  const move = (ev) => ed.status(`keyframe ${i}: duration ${durationAt(ev.clientX).toFixed(2)} s (release to set)`);
  const up = (ev) => {
    handle.removeEventListener("pointermove", move);
    handle.removeEventListener("pointerup", up);
    const duration = Number(durationAt(ev.clientX).toFixed(2));
    if (duration === d0) { ed.status(`keyframe ${i}: duration ${d0} s`); return; }
    snapshot(ed);
    kfs[i].duration = duration;
    edited(ed);
    ed.status(`keyframe ${i}: duration ${duration} s`);
  };
  handle.addEventListener("pointermove", move);
  handle.addEventListener("pointerup", up);
}

/** A timeline block picked up: which keyframe is being dragged. */
function onTimelineDrag(ed, e) {
  const block = e.target.closest?.("[data-tl]");
  if (!block) return;
  if (e.target.closest?.("[data-resize]")) { e.preventDefault(); return; } // its edge: a duration, not an order
  ed.dragged = +block.dataset.tl;
  e.dataTransfer.effectAllowed = "move";
  e.dataTransfer.setData("text/plain", block.dataset.tl);
}

/** A timeline block dropped on another: the dragged keyframe takes that one's place. */
function onTimelineDrop(ed, e) {
  const block = e.target.closest("[data-tl]");
  if (!block || ed.dragged === undefined) return;
  e.preventDefault();
  const from = ed.dragged;
  const to = +block.dataset.tl;
  ed.dragged = undefined;
  if (from !== to) guarded(ed, () => moveKeyframe(ed, from, to));
}

/** A keyframe row's buttons: move up or down, duplicate, delete; the selection stays on its keyframe. */
async function keyframeAction(ed, kact, i) {
  const { state } = ed;
  if (kact === "up" && i > 0) await moveKeyframe(ed, i, i - 1);
  if (kact === "down" && i < state.anim.keyframes.length - 1) await moveKeyframe(ed, i, i + 1);
  if (kact === "duplicate") {
    await edit(ed, "duplicate", { index: i }); state.selected = i + 1;
    ed.status(`duplicated keyframe ${i}`);
  }
  if (kact === "delete") {
    await edit(ed, "delete", { index: i });
    if (i < state.selected) state.selected--;
    ed.status(`deleted keyframe ${i}`);
  }
  render(ed);
}

/** A keyframe to another place (its row's arrows, or dragged on the timeline); the selection goes with it. */
async function moveKeyframe(ed, from, to) {
  await edit(ed, "move", { index: from, new_index: to });
  ed.state.selected = to;
  render(ed);
  ed.status(`moved keyframe ${from} to ${to}`);
}

/** A goal's ✕: the joint leaves the selected keyframe (goal and torque). */
function removeGoal(ed, j) {
  snapshot(ed);
  const kf = ed.state.anim.keyframes[ed.state.selected];
  delete kf.goals[j];
  if (kf.torque) delete kf.torque[j];
  edited(ed);
  ed.status(`keyframe ${ed.state.selected}: ${j} removed`);
}

/** "add joint": the chosen joint joins the selected keyframe at the goal it is held at in the record table. */
function addGoal(ed) {
  const { state } = ed;
  snapshot(ed);
  const j = ed.$('[data-role="add-joint"]').value;
  const limit = inLimits(ed, j, state.held[j] ?? 0);
  state.anim.keyframes[state.selected].goals[j] = limit.value;
  edited(ed);
  ed.status(`keyframe ${state.selected}: ${j} added at ${limit.value} deg (its goal in the record table)`);
}

/** Changes: the ghosts menu, an upload, a keyframe's field, a goal or torque, the record table, the name box. */
function onChange(ed, e) {
  const t = e.target;
  if (t.dataset.role === "ghosts") { setGhosts(ed, t.value); return; }
  if (t.dataset.role === "upload" && t.files?.length) {
    const f = t.files[0];
    guarded(ed, () => upload(ed, f));
    return;
  }
  const kfRow = t.closest("tr[data-kf]");
  if (kfRow && t.dataset.field) { editKeyframeField(ed, t, +kfRow.dataset.kf); return; }
  const detailRow = t.closest("[data-role=detail] tr[data-joint]");
  if (detailRow) { editGoal(ed, t, detailRow.dataset.joint); return; }
  const jointRow = t.closest("[data-role=joints] tr[data-joint]");
  if (jointRow) { editRecordJoint(ed, t, jointRow); renderGroups(ed); }
  const groupRow = t.closest("[data-role=groups] tr[data-group]");
  if (groupRow) editGroup(ed, t, groupRow.dataset.group);
  if (t.dataset.role === "name" && ed.state.anim) {
    snapshot(ed); ed.state.anim.name = t.value; edited(ed); ed.status(`renamed to ${t.value}`);
  }
  if (t.dataset.role === "override") {
    ed.status(t.checked ? "limits overridden: goals outside them may be saved and played (lab only)"
      : "limits enforced again");
  }
}

/** A keyframe's name, duration or pause edited in its row (times never below zero). */
function editKeyframeField(ed, t, index) {
  snapshot(ed);
  const kf = ed.state.anim.keyframes[index];
  if (t.dataset.field === "name") kf.name = t.value || undefined;
  else kf[t.dataset.field] = Math.max(0, Number(t.value) || 0);
  edited(ed);
  ed.status(`keyframe ${index}: ${t.dataset.field} ${kf[t.dataset.field] ?? "none"}`);
}

/** A goal or torque of the selected keyframe edited; a goal that is not a number is refused and put back. */
function editGoal(ed, t, j) {
  const { state } = ed;
  snapshot(ed);
  const kf = state.anim.keyframes[state.selected];
  if (t.dataset.goal !== undefined) {
    const v = t.value.trim() === "" ? NaN : Number(t.value);
    if (!Number.isFinite(v)) {
      ed.before = null; t.value = kf.goals[j]; ed.status(`${j}: a goal is a number of degrees`, true);
      return;
    }
    const limit = inLimits(ed, j, v);
    kf.goals[j] = limit.value;
    state.notes[`goal|${state.selected}|${j}`] = limit.clamped ? `outside [${limit.j.lower.toFixed(1)}, ${limit.j.upper.toFixed(1)}]: ` +
      `set to ${fmtDeg(limit.value)}` : "";
    edited(ed);
    ed.status(limit.clamped ? clampedText(j, v, limit) : `keyframe ${state.selected}: ${j} ${fmtDeg(limit.value)} deg`,
      limit.clamped);
    return;
  }
  if (t.dataset.torque !== undefined) {
    kf.torque = kf.torque || {};
    if (t.value === "") delete kf.torque[j]; else kf.torque[j] = Number(t.value);
  }
  edited(ed);
  ed.status(`keyframe ${state.selected}: ${j} torque ${t.value === "" ? "unchanged" : torqueLabel(Number(t.value))}`);
}

/** The record table: recorded or not, limp or not (sent at once), a typed goal (sent at once, slider follows). */
function editRecordJoint(ed, t, row) {
  const { state } = ed;
  const j = row.dataset.joint;
  if (t.dataset.rec !== undefined) { if (t.checked) state.recordJoints.add(j); else state.recordJoints.delete(j); }
  if (t.dataset.limp !== undefined) {
    if (t.checked) state.limp.add(j); else state.limp.delete(j);
    sendGoals(ed, true);
  }
  if (t.dataset.held !== undefined) {
    const typed = t.value.trim() === "" ? NaN : Number(t.value);
    if (!Number.isFinite(typed)) {
      t.value = fmtDeg(state.held[j] ?? 0); ed.status(`${j}: a goal is a number of degrees`, true);
      return;
    }
    const limit = inLimits(ed, j, typed);
    state.held[j] = limit.value;
    t.value = fmtDeg(limit.value);
    row.querySelector("[data-slider]").value = limit.value;
    sendGoals(ed, true);
    noteJoint(ed, "held", j, limit.clamped ? `outside [${limit.j.lower.toFixed(1)}, ${limit.j.upper.toFixed(1)}]: ` +
      `set to ${fmtDeg(limit.value)}` : "");
    if (limit.clamped) ed.status(clampedText(j, typed, limit), true);
  }
}

/** A slider dragged: the goal follows it (its number box too) and goes to the robot, throttled. */
function onSliderInput(ed, e) {
  const t = e.target;
  if (t.dataset.slider === undefined) return;
  const row = t.closest("tr[data-joint]");
  ed.state.held[row.dataset.joint] = servoDeg(Number(t.value));
  row.querySelector("[data-held]").value = fmtDeg(ed.state.held[row.dataset.joint]);
  noteJoint(ed, "held", row.dataset.joint, ""); // a slider stays inside the limits
  sendGoals(ed);
}
