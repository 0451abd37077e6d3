// Recordings: the recordings folder (size, duration), start/stop a manual recording, bookmark, open in replay.
// Recording lives in the server (it goes on with the browser closed) and sends nothing to robots: fine in match mode.

import { api } from "../lab_api.js";
import { esc } from "../dom.js";

function size(bytes) {
  return bytes > 1e9 ? `${(bytes / 1e9).toFixed(2)} GB` : bytes > 1e6 ? `${(bytes / 1e6).toFixed(1)} MB`
    : `${(bytes / 1e3).toFixed(0)} kB`;
}

function clock(seconds) {
  if (seconds === undefined || seconds === null) return "";
  const m = Math.floor(seconds / 60);
  return `${m}:${String(Math.floor(seconds % 60)).padStart(2, "0")}`;
}

function running(status, label) {
  if (!status) return "";
  return `<div class="rec-running" data-kind="${label}"><span class="badge bad">● REC</span> ${label}:
    ${esc(status.name)} — ${status.messages} messages, ${clock(status.duration_s)}, ${status.bookmarks} bookmarks
    ${status.dropped ? `<span class="badge warn">${esc(status.dropped)} dropped</span>` : ""}</div>`;
}

export default {
  id: "recordings",
  title: "Recordings",
  size: [1, 2],
  create(body, ctx) {
    body.innerHTML = `<div class="rec-controls">
        <input class="rec-name" placeholder="name (optional)" size="14" aria-label="recording name">
        <button class="rec-start" type="button">● record</button>
        <button class="rec-stop" type="button" disabled>■ stop</button>
        <button class="rec-mark" type="button" disabled title="mark this moment in the running recordings">bookmark</button>
      </div>
      <div class="rec-status"></div><div class="rec-error bad" hidden></div>
      <table class="grid-table rec-files"><thead><tr><th>file</th><th>size</th><th>duration</th><th></th></tr></thead>
      <tbody></tbody></table>`;
    const $ = (sel) => body.querySelector(sel);
    const errorEl = $(".rec-error");
    function fail(err) { errorEl.hidden = false; errorEl.textContent = err.message; }
    async function act(method, path, payload) {
      errorEl.hidden = true;
      try { await api(method, path, payload); } catch (err) { fail(err); }
      refresh();
    }
    $(".rec-start").addEventListener("click", () => act("POST", "api/recordings/start", { name: $(".rec-name").value }));
    $(".rec-stop").addEventListener("click", () => act("POST", "api/recordings/stop"));
    $(".rec-mark").addEventListener("click", () => {
      const name = prompt("bookmark name", "note");
      if (name) act("POST", "api/recordings/bookmark", { name });
    });
    $(".rec-files").addEventListener("click", (e) => {
      const name = e.target.closest("button[data-open]")?.dataset.open;
      if (name) openInReplay(name);
    });

    /** Opens the file in replay; the page then brings the replay view and the playback bar into sight. */
    async function openInReplay(name) {
      errorEl.hidden = true;
      try {
        await api("POST", "api/replay/open", { path: name });
        ctx.store.emit("replay-opened", name);
      } catch (err) { fail(err); }
    }

    async function refresh() {
      let listing;
      try { listing = await api("GET", "api/recordings"); } catch (err) { fail(err); return; }
      $(".rec-status").innerHTML = running(listing.manual, "manual") + running(listing.match, "match") ||
        `<div class="empty">not recording${listing.auto_match ? " (matches are recorded automatically)" : ""}</div>`;
      $(".rec-start").disabled = !!listing.manual;
      $(".rec-stop").disabled = !listing.manual;
      $(".rec-mark").disabled = !listing.manual && !listing.match;
      $(".rec-files tbody").innerHTML = listing.files.map((f) => `<tr data-file="${esc(f.name)}">
        <td>${esc(f.name)}</td><td>${size(f.size_bytes)}</td>
        <td>${f.recording ? "recording…" : f.error ? `<span class="bad">${esc(f.error)}</span>` : clock(f.duration_s)}</td>
        <td>${f.recording ? "" : `<button type="button" data-open="${esc(f.name)}">replay</button>
          <a class="button" data-download="${esc(f.name)}" href="api/recordings/files/${esc(encodeURIComponent(f.name))}"
            download="${esc(f.name)}">download</a>${f.series ? ` <a class="button" data-download-series="${esc(f.name)}"
            href="api/recordings/series/${esc(encodeURIComponent(f.name))}" title="${esc(f.series.join(", "))}"
            >all ${f.series.length} files (zip)</a>` : ""}`}</td></tr>`)
        .join("") || `<tr><td colspan="4" class="empty">no recordings yet</td></tr>`;
    }
    refresh();
    const timer = setInterval(refresh, 2000);
    return { destroy() { clearInterval(timer); } };
  },
};
