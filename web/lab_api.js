// The control API from the browser (lab tools): JSON in and out, the server's reason as the error message.

/** The control token: ?token= in the page URL (remembered), needed only when the server listens beyond loopback. */
function token() {
  const fromUrl = new URLSearchParams(location.search).get("token");
  if (fromUrl) localStorage.setItem("pitchside.token", fromUrl);
  return fromUrl || localStorage.getItem("pitchside.token") || "";
}

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
  const t = token();
  if (t) headers.authorization = `Bearer ${t}`;
  const reply = await fetch(path, { method, headers, keepalive,
    body: body === undefined ? undefined : JSON.stringify(body) });
  let data = null;
  try { data = await reply.json(); } catch { data = null; }
  if (!reply.ok) throw new ApiError(reply.status, data?.detail ?? reply.statusText);
  return data;
}

/** A path with the control token as ?token= (for EventSource, which cannot send headers). */
export function withToken(path) {
  const t = token();
  return t ? `${path}${path.includes("?") ? "&" : "?"}token=${encodeURIComponent(t)}` : path;
}

export function esc(text) {
  return String(text).replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;",
    "'": "&#39;" })[c]);
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
    const html = ids.map((id) => `<option value="${esc(id)}">${esc(id)}</option>`).join("");
    if (select.innerHTML !== html) select.innerHTML = html;
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
