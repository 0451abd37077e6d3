// The control API from the browser (lab tools): JSON in and out, the server's reason as the error message.
// The credential is the server's HttpOnly session cookie (set when the page was opened through the link the
// server printed, or by signing in with the token): the browser sends it by itself, and no script can read it.

import { setOptions } from "./dom.js";

export class ApiError extends Error {
  constructor(status, detail) {
    super(typeof detail === "string" ? detail : JSON.stringify(detail));
    this.status = status;
  }
}

/** fetch() against the server; throws ApiError with the server's "detail" (e.g. the node's own refusal).
 * keepalive: the request outlives the page (a clean-up sent while the page goes away). */
export async function api(method, path, body, { keepalive = false } = {}) {
  const headers = { "content-type": "application/json" };
  const reply = await fetch(path, { method, headers, keepalive, credentials: "same-origin",
    body: body === undefined ? undefined : JSON.stringify(body) });
  let data = null;
  try { data = await reply.json(); } catch { data = null; }
  if (!reply.ok) throw new ApiError(reply.status, data?.detail ?? reply.statusText);
  return data;
}

/** The control API's path of one robot (its id encoded), the start of every per-robot request. */
export function robotPath(robot) {
  return `api/robots/${encodeURIComponent(robot)}`;
}

/** The numeric fields of the newest message of a robot's stream, [{path, label}], as the server defines them
 * (schemas/numeric.py): path addresses the number in a msg frame's data, label names array elements. */
export async function numericFields(robot, topic) {
  const path = topic.split("/").map(encodeURIComponent).join("/");
  return (await api("GET", `api/fields/${encodeURIComponent(robot)}/${path}`)).fields;
}

/** A <select> of the robots the page knows, following the focused robot until the user picks one. */
export function robotPicker(select, ctx, onChange) {
  let chosen = "";
  let reported = null;
  function report(robot) {
    if (robot === reported) return;
    reported = robot;
    onChange(robot);
  }
  function refresh() {
    const ids = ctx.store.robotIds();
    const want = chosen || ctx.store.focus || ids[0] || "";
    if (want && !ids.includes(want)) ids.push(want);
    setOptions(select, ids.map((id) => [id, id]));
    select.value = want;
    if (want) report(want);
  }
  select.addEventListener("change", () => { chosen = select.value; report(chosen); });
  const offs = [ctx.store.on("robots", refresh), ctx.store.on("focus", refresh)];
  refresh();
  return { robot: () => select.value, off: () => offs.forEach((off) => off()) };
}

/** Text shown instead of a lab panel in match mode. */
export const MATCH_MODE_TEXT = "match mode: the server sends nothing to robots, so this lab tool is off";
/** ... and in a browser that has not shown the token. */
export const VIEW_ONLY_TEXT = "view only: open the link the server printed at start-up, or sign in with its token "
  + "in the top bar, to use this lab tool";

/** Draws the reason a lab tool is off (match mode, or no credential) and returns true; false if it may run. */
export function labToolOff(body, config) {
  const reason = config.match_mode ? MATCH_MODE_TEXT : config.control ? "" : VIEW_ONLY_TEXT;
  if (!reason) return false;
  const note = document.createElement("div");
  note.className = "empty";
  note.textContent = reason;
  body.replaceChildren(note);
  return true;
}
