// The playback bar: while a log is open, a bar fixed to the bottom of the window says REPLAY and which file, and holds
// the timeline (time labels, bookmarks by name: the GameController's events, a cursor), play/pause, step, speed and
// close, and "bookmark here": a named note at the replay's position, kept in a sidecar beside the log (never in the
// log itself) and listed on the timeline whenever the log is opened again. Fixed, so it is in sight however the page is scrolled and whichever panels are shown; a replay is a source of
// its own, so the page says so wherever it shows (this bar, the REPLAY robot cards, the field view).

import { api } from "./lab_api.js";
import { esc } from "./dom.js";

export const SPEEDS = [0.1, 0.25, 0.5, 1, 2, 5, 10];
const TICK_STEPS_S = [1, 2, 5, 10, 15, 30, 60, 120, 300, 600, 900, 1800, 3600];
const MAX_TICKS = 10;
const SEEK_STEP_S = 5; // the arrow keys on the timeline

/** m:ss.s (or m:ss for labels). */
export function clock(seconds, decimals = 1) {
  // rounded first, so 59.98 s reads 1:00.0 (not 0:60.0); labels without decimals are cut, as a clock shows seconds
  const scale = 10 ** decimals;
  const s = decimals ? Math.round(Math.max(0, seconds) * scale) / scale : Math.max(0, seconds);
  const m = Math.floor(s / 60);
  const rest = decimals ? (s % 60).toFixed(decimals).padStart(3 + decimals, "0") : String(Math.floor(s % 60)).padStart(2, "0");
  return `${m}:${rest}`;
}

/** Time labels at a round step, at most MAX_TICKS of them. */
function ticks(duration) {
  const step = TICK_STEPS_S.find((s) => duration / s <= MAX_TICKS) ?? TICK_STEPS_S.at(-1);
  const out = [];
  for (let t = 0; t <= duration + 1e-9; t += step) out.push(t);
  return out;
}

export class PlaybackBar {
  /** parent: where the bar goes (the body); store: the page's store (its "replay-opened" event asks for a refresh). */
  constructor(parent, store) {
    this.store = store;
    this.status = { state: "closed" };
    this.info = null;
    this.dragging = false;
    const el = this.el = document.createElement("div");
    el.className = "playback-bar";
    el.hidden = true;
    el.setAttribute("role", "region");
    el.setAttribute("aria-label", "replay playback");
    el.innerHTML = `<div class="playback-row">
        <span class="badge replay playback-banner" title="what you see of replay.* robots is this log, not live">▶ REPLAY</span>
        <span class="playback-file"></span>
        <button class="playback-play" type="button">▶ play</button>
        <button class="playback-step" type="button" title="next message">step</button>
        <label>speed <select class="playback-speed">${SPEEDS.map((s) => `<option value="${s}">${s}x</option>`).join("")}</select></label>
        <span class="playback-state badge"></span>
        <span class="playback-time"></span>
        <span class="spacer"></span>
        <span class="playback-note-form"><input class="playback-note" size="16" maxlength="120"
            aria-label="name of a bookmark at this position" placeholder="bookmark name (optional)">
          <button class="playback-bookmark" type="button"
            title="a named bookmark at this position; kept beside the log, listed here next time">★ bookmark here</button></span>
        <span class="playback-noted" role="status"></span>
        <span class="playback-error bad" hidden></span>
        <button class="playback-close" type="button" title="close the log: its replay.* robots go">✕ close</button>
      </div>
      <div class="playback-marks"></div>
      <div class="playback-track" tabindex="0" role="slider" aria-label="position in the log"
        title="click or drag to seek; ← → by ${SEEK_STEP_S} s"><div class="playback-done"></div><div class="playback-cursor"></div></div>
      <div class="playback-ticks"></div>`;
    parent.append(el);
    const $ = (sel) => el.querySelector(sel);
    this.$ = $;
    $(".playback-play").addEventListener("click", () => this.call(this.status.state === "playing" ? "pause" : "play"));
    $(".playback-step").addEventListener("click", () => this.call("step", { count: 1 }));
    $(".playback-speed").addEventListener("change", (e) => this.call("speed", { speed: +e.target.value }));
    $(".playback-close").addEventListener("click", () => this.call("close"));
    $(".playback-bookmark").addEventListener("click", () => this.bookmark());
    $(".playback-note").addEventListener("keydown", (e) => { if (e.key === "Enter") this.bookmark(); });
    $(".playback-marks").addEventListener("click", (e) => {
      const mark = e.target.closest("[data-t]");
      if (mark) this.seek(+mark.dataset.t);
    });
    const track = $(".playback-track");
    track.addEventListener("pointerdown", (e) => {
      this.dragging = true;
      track.setPointerCapture(e.pointerId);
      this.showPosition(this.timeAt(e));
    });
    track.addEventListener("pointermove", (e) => { if (this.dragging) this.showPosition(this.timeAt(e)); });
    track.addEventListener("pointerup", (e) => { this.dragging = false; this.seek(this.timeAt(e)); });
    track.addEventListener("keydown", (e) => {
      const by = e.key === "ArrowRight" ? SEEK_STEP_S : e.key === "ArrowLeft" ? -SEEK_STEP_S : 0;
      if (by && this.status.position_s !== undefined) { e.preventDefault(); this.seek(this.status.position_s + by); }
    });
    store.on("replay-opened", () => this.refresh());
    store.on("replay-bookmarked", () => this.reloadMarks()); // a note added elsewhere (the recordings panel)
    this.refresh();
    this.timer = setInterval(() => this.refresh(), 250);
  }

  get duration() {
    return this.info?.duration_s ?? this.status.duration_s ?? 0;
  }

  timeAt(e) {
    const box = this.$(".playback-track").getBoundingClientRect();
    return Math.max(0, Math.min(1, (e.clientX - box.left) / box.width)) * this.duration;
  }

  seek(t) {
    return this.call("seek", { t_s: Math.max(0, Math.min(t, this.duration)) });
  }

  /** A note at the replay's position, named as typed (or by its time); listed on the timeline at once. */
  async bookmark() {
    const input = this.$(".playback-note");
    const at = this.status.position_s ?? 0;
    const name = input.value.trim() || `note ${clock(at)}`;
    this.$(".playback-error").hidden = true;
    try {
      const note = await api("POST", "api/replay/bookmark", { name, t_s: at });
      input.value = "";
      this.$(".playback-noted").textContent = `★ "${note.name}" at ${clock(note.t_s)}`;
      await this.reloadMarks();
    } catch (err) {
      this.fail(err);
    }
  }

  async reloadMarks() {
    try { this.info = await api("GET", "api/replay/info"); } catch { return; }
    this.renderTimeline();
  }

  async call(path, payload) {
    this.$(".playback-error").hidden = true;
    try {
      this.status = await api("POST", `api/replay/${path}`, payload);
      this.render();
    } catch (err) {
      this.fail(err);
    }
  }

  fail(err) {
    const el = this.$(".playback-error");
    el.hidden = false;
    el.textContent = err.message;
  }

  async refresh() {
    try { this.status = await api("GET", "api/replay"); } catch { return; }
    const open = this.status.state !== "closed" && this.status.state !== "loading";
    if (open && this.info?.path !== this.status.path) {
      try { this.info = await api("GET", "api/replay/info"); } catch { this.info = null; }
      this.renderTimeline();
    } else if (!open) {
      if (this.info) this.store.emit("replay-closed");
      this.info = null;
      this.$(".playback-noted").textContent = "";
    }
    this.render();
  }

  /** The parts that change only with the file: time labels and bookmarks. */
  renderTimeline() {
    const duration = Math.max(this.duration, 1e-9);
    const pct = (t) => `${(100 * t) / duration}%`;
    this.$(".playback-ticks").innerHTML = this.info ? ticks(this.info.duration_s).map((t) =>
      `<span class="playback-tick" style="left: ${pct(t)}">${clock(t, 0)}</span>`).join("") : "";
    // names on two rows, so neighbouring events stay readable
    // notes added to the log ("note") apart from its own bookmarks ("log": GameController events, while recording)
    this.$(".playback-marks").innerHTML = (this.info?.bookmarks ?? []).map((b, i) =>
      `<button type="button" class="playback-mark row${i % 2} ${b.kind === "note" ? "note" : ""}" style="left: ${pct(b.t_s)}"
        data-t="${b.t_s}" data-name="${esc(b.name)}" data-kind="${esc(b.kind)}"
        title="${b.kind === "note" ? "★ note" : "in the log"}: ${esc(b.name)} at ${clock(b.t_s)}: seek there"
        >${b.kind === "note" ? "★ " : ""}${esc(b.name)}</button>`).join("");
  }

  showPosition(t) {
    const pct = `${(100 * t) / Math.max(this.duration, 1e-9)}%`;
    this.$(".playback-cursor").style.left = pct;
    this.$(".playback-done").style.width = pct;
    this.$(".playback-time").textContent = `${clock(t)} / ${clock(this.duration)}`;
  }

  render() {
    const s = this.status;
    const open = s.state !== "closed" && s.state !== "loading";
    const was = !this.el.hidden;
    this.el.hidden = s.state === "closed";
    document.body.classList.toggle("replaying", !this.el.hidden);
    if (!was && !this.el.hidden) this.renderTimeline();
    if (this.el.hidden) return;
    const $ = this.$;
    $(".playback-file").textContent = s.path ? s.path.split("/").pop() : "";
    $(".playback-file").title = s.path ?? "";
    $(".playback-state").textContent = s.state;
    $(".playback-state").className = `playback-state badge ${s.state === "playing" ? "ok" : "warn"}`;
    $(".playback-play").textContent = s.state === "playing" ? "❚❚ pause" : "▶ play";
    for (const sel of [".playback-play", ".playback-step", ".playback-speed", ".playback-bookmark"]) $(sel).disabled = !open;
    if (s.speed) $(".playback-speed").value = String(s.speed);
    if (open && s.duration_s !== undefined && !this.dragging) this.showPosition(s.position_s);
    $(".playback-track").setAttribute("aria-valuenow", String(Math.round(s.position_s ?? 0)));
    if (s.error) this.fail(new Error(s.error));
  }
}
