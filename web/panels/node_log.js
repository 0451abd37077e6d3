// Node log: every node's log records (rcl_interfaces/msg/Log on rosout), newest first, filtered by level, robot and
// node, with a search over the text. In a replay it shows the log's records as they play (a seek back starts over).

import { expose } from "../test_hooks.js";
import { esc, setOptions } from "../dom.js";
import { constantNames } from "../msgtypes.js";

const LOG = "rcl_interfaces/msg/Log";
const KEEP = 2000; // records held in the page; older ones drop off
const SHOWN = 200; // rows drawn at once: the filters find older ones

/** The panel's state: records, filters, and the elements it draws into. */
function newLog(body) {
  body.innerHTML = `<div class="lab-bar">
      <select data-role="level" title="lowest level shown"></select>
      <select data-role="robot" title="robot"></select>
      <input data-role="node" placeholder="node" size="10">
      <input data-role="search" type="search" placeholder="search text" size="18">
      <span data-role="count" class="muted"></span></div>
    <table class="grid-table node-log"><thead><tr><th>time</th><th>robot</th><th>node</th><th>level</th>
      <th>message</th></tr></thead><tbody></tbody></table>`;
  const $ = (role) => body.querySelector(`[data-role="${role}"]`);
  return { records: [], dirty: true, robots: new Set(), lastStamp: new Map(),
    el: { level: $("level"), robot: $("robot"), node: $("node"), search: $("search"), count: $("count"),
      rows: body.querySelector("tbody") } };
}

/** The level names of the message itself (DEBUG ... FATAL), lowest first. */
function levelNames() {
  return [...constantNames(LOG).entries()].sort((a, b) => a[0] - b[0]);
}

/** One arrived record; a record older than the last of its robot means a replay went back: start over. */
function add(log, frame) {
  const d = frame.data;
  const t = d.stamp.sec + d.stamp.nanosec / 1e9;
  if (t < (log.lastStamp.get(frame.robot) ?? -Infinity) - 1) log.records = log.records.filter((r) => r.robot !== frame.robot);
  log.lastStamp.set(frame.robot, t);
  // ROS 2's logger name is <namespace>.<node> (robot1.hcm); the robot has its own column
  const node = d.name.startsWith(`${frame.robot}.`) ? d.name.slice(frame.robot.length + 1) : d.name;
  log.records.push({ t, robot: frame.robot, node, level: d.level, text: d.msg, where: `${d.file}:${d.line}` });
  if (log.records.length > KEEP) log.records.splice(0, log.records.length - KEEP);
  if (!log.robots.has(frame.robot)) {
    log.robots.add(frame.robot);
    refreshRobots(log);
  }
  log.dirty = true;
}

/** The robot filter lists every robot seen so far. */
function refreshRobots(log) {
  const chosen = log.el.robot.value;
  setOptions(log.el.robot, [["", "all robots"], ...[...log.robots].sort().map((r) => [r, r])]);
  log.el.robot.value = chosen;
}

/** Records passing the filters, newest first. */
function visible(log) {
  const min = Number(log.el.level.value || 0);
  const robot = log.el.robot.value;
  const node = log.el.node.value.trim().toLowerCase();
  const words = log.el.search.value.trim().toLowerCase().split(/\s+/).filter(Boolean);
  return log.records.filter((r) => r.level >= min && (!robot || r.robot === robot)
    && (!node || r.node.toLowerCase().includes(node))
    && words.every((w) => r.text.toLowerCase().includes(w))).reverse();
}

/** Draws the rows (escaped) and the count. */
function render(log) {
  if (!log.dirty) return;
  log.dirty = false;
  const names = constantNames(LOG);
  const rows = visible(log);
  log.el.count.textContent = `${rows.length} of ${log.records.length}`;
  log.el.rows.innerHTML = rows.slice(0, SHOWN).map((r) => `<tr class="log-level-${esc(r.level)}" data-level="${esc(r.level)}">
    <td>${new Date(r.t * 1000).toLocaleTimeString()}</td><td>${esc(r.robot)}</td><td>${esc(r.node)}</td>
    <td>${esc(names.get(r.level) ?? r.level)}</td><td title="${esc(r.where)}"><pre>${esc(r.text)}</pre></td></tr>`)
    .join("");
}

export default {
  id: "node_log",
  title: "Node log",
  size: [2, 2],
  create(body, ctx) {
    const log = newLog(body);
    setOptions(log.el.level, levelNames().map(([value, name]) => [String(value), `${name} and above`]));
    const [, second] = levelNames(); // nodes send from the level above the lowest (debug) up: show all they send
    log.el.level.value = second ? String(second[0]) : "0";
    for (const el of [log.el.level, log.el.robot, log.el.node, log.el.search]) {
      el.addEventListener("input", () => { log.dirty = true; render(log); });
    }
    const offs = [ctx.subscribe("rosout", 0, (frame) => add(log, frame))];
    const timer = setInterval(() => render(log), 300);
    expose("nodeLog", log);
    return { destroy() { clearInterval(timer); offs.forEach((off) => off()); } };
  },
};
