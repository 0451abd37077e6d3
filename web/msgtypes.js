// What the page knows of the messages: the names of their constants and the topic table, served by the server from
// the .msg files and schemas/topics.py (GET /api/schemas), so a number is never shown bare and the page keeps no
// copy of a message definition of its own.

const HCM_STATE = "humanoid_league_msgs/msg/RobotControlState";
const GAME_STATE = "humanoid_league_msgs/msg/GameState";
const OBSTACLE = "humanoid_league_msgs/msg/ObstacleRelative";
const OVERVIEW = "pitchside_msgs/msg/RobotOverview";
const DIAGNOSTIC_STATUS = "diagnostic_msgs/msg/DiagnosticStatus";
/** HCM states a team wants to see at once (the robot is down, limp or broken). */
const BAD_HCM_STATES = new Set(["FALLING", "FALLEN", "GETTING_UP", "MOTOR_OFF", "HCM_OFF", "HARDWARE_PROBLEM",
  "PICKED_UP"]);
const PENALTY_HCM_STATES = new Set(["PENALTY", "PENALTY_ANIMATION"]);

let served = { constants: {}, topics: {} };
const tables = new Map(); // "type|prefix" -> Map(value -> name)

/** Takes the server's GET /api/schemas answer; called once before any panel starts. */
export function learnSchemas(schemas) {
  served = schemas;
  tables.clear();
}

/** value -> name of the constants of a message type that start with prefix (prefix removed), as the .msg says. */
export function constantNames(type, prefix = "") {
  const key = `${type}|${prefix}`;
  if (!tables.has(key)) {
    const names = new Map();
    for (const [name, value] of Object.entries(served.constants[type] ?? {})) {
      if (name.startsWith(prefix)) names.set(value, name.slice(prefix.length));
    }
    tables.set(key, names);
  }
  return tables.get(key);
}

/** Topics published only when something happens: silence on them is normal (the topic table's "event"). */
export function eventTopics() {
  return new Set(Object.entries(served.topics).filter(([, t]) => t.event).map(([name]) => name));
}

export function hcmName(state) {
  const unknown = state === undefined || state === served.constants[OVERVIEW]?.UNKNOWN;
  return constantNames(HCM_STATE).get(state) ?? (unknown ? "unknown" : `state ${state}`);
}

export function hcmStateIsBad(state) {
  return BAD_HCM_STATES.has(constantNames(HCM_STATE).get(state));
}

export function hcmStateIsPenalty(state) {
  return PENALTY_HCM_STATES.has(constantNames(HCM_STATE).get(state));
}

export function gameName(state) {
  return constantNames(GAME_STATE, "GAMESTATE_").get(state) ?? "unknown";
}

export function secondaryName(state) {
  return constantNames(GAME_STATE, "STATE_").get(state) ?? "";
}

/** An obstacle's colour constant by name ("ROBOT_MAGENTA"), "" if unknown. */
export function obstacleColor(color) {
  return constantNames(OBSTACLE).get(color) ?? "";
}

/** A DiagnosticStatus level by name ("WARN"), or the number when the .msg has no name for it. */
export function diagnosticLevelName(level) {
  return constantNames(DIAGNOSTIC_STATUS).get(level) ?? String(level);
}

/** The value of a DiagnosticStatus level ("STALE" -> 3). */
export function diagnosticLevel(name) {
  return served.constants[DIAGNOSTIC_STATUS]?.[name];
}

/** Yaw of a geometry_msgs/Quaternion. */
export function yaw(q) {
  return Math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z));
}

export function fmtClock(seconds) {
  const s = Math.max(0, Math.round(seconds));
  return `${Math.floor(s / 60)}:${String(s % 60).padStart(2, "0")}`;
}

/** A canvas sized to its element in device pixels; returns the 2D context scaled to CSS pixels. */
export function fitCanvas(canvas) {
  const ratio = window.devicePixelRatio || 1;
  const w = Math.max(1, canvas.clientWidth), h = Math.max(1, canvas.clientHeight);
  if (canvas.width !== Math.round(w * ratio) || canvas.height !== Math.round(h * ratio)) {
    canvas.width = Math.round(w * ratio);
    canvas.height = Math.round(h * ratio);
  }
  const ctx = canvas.getContext("2d");
  ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
  return { ctx, w, h };
}

export function css(name) {
  return getComputedStyle(document.documentElement).getPropertyValue(name).trim();
}
