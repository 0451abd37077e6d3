// Names of the message constants the panels show (humanoid_league_msgs), so a number is never shown bare.

export const HCM_STATES = ["CONTROLLABLE", "FALLING", "FALLEN", "GETTING_UP", "ANIMATION_RUNNING", "STARTUP",
  "SHUTDOWN", "PENALTY", "PENALTY_ANIMATION", "RECORD", "WALKING", "MOTOR_OFF", "HCM_OFF", "HARDWARE_PROBLEM",
  "PICKED_UP"];
export const GAME_STATES = ["INITIAL", "READY", "SET", "PLAYING", "FINISHED"];
export const SECONDARY_STATES = ["NORMAL", "PENALTYSHOOT", "OVERTIME", "TIMEOUT", "DIRECT_FREEKICK",
  "INDIRECT_FREEKICK", "PENALTYKICK", "CORNER_KICK", "GOAL_KICK", "THROW_IN"];
export const OBSTACLE_COLORS = ["UNDEFINED", "ROBOT_UNDEFINED", "ROBOT_MAGENTA", "ROBOT_CYAN", "HUMAN", "POLE"];
export const BAD_HCM_STATES = new Set([1, 2, 3, 11, 12, 13, 14]);

export function hcmName(state) {
  return HCM_STATES[state] ?? (state === 255 || state === undefined ? "unknown" : `state ${state}`);
}

export function gameName(state) {
  return GAME_STATES[state] ?? "unknown";
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
