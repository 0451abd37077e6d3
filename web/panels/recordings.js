// Recordings: the recordings folder (size, duration), start/stop a manual recording, bookmark, open in replay.
// The list is refreshed every 2 s while a match records, so it changes only what changed: a row whose file did not
// change stays the same element, and a click on its "replay" lands where the pointer is. "bookmark" marks the open
// replay at its position when a log is replayed (a note beside the log, as the playback bar's "bookmark here"),
// else the running recordings.
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

/** One file's row: name with size and duration under it, its buttons beside (they wrap in a narrow panel). */
function fileRow(f) {
  const facts = f.recording ? `${size(f.size_bytes)} · recording…`
    : f.error ? `${size(f.size_bytes)} · <span class="bad">${esc(f.error)}</span>` : `${size(f.size_bytes)} · ${clock(f.duration_s)}`;
  const pulled = f.pulled ? ` · robot logs: ${f.pulled.length ? esc(f.pulled.join(", ")) : "none"}` : "";
  const buttons = f.recording ? "" : `<button type="button" data-open="${esc(f.name)}">replay</button>
    <a class="button" data-download="${esc(f.name)}" href="api/recordings/files/${esc(encodeURIComponent(f.name))}"
      download="${esc(f.name)}">download</a>${f.series ? `<a class="button" data-download-series="${esc(f.name)}"
      href="api/recordings/series/${esc(encodeURIComponent(f.name))}" title="${esc(f.series.join(", "))}"
      >all ${f.series.length} files (zip)</a>` : ""}`;
  return `<td class="rec-file"><span class="rec-file-name">${esc(f.name)}</span><span class="rec-facts">${facts}${pulled}</span></td>
    <td class="rec-actions-cell"><div class="rec-actions">${buttons}</div></td>`;
}

/** Sets an element's markup only when it differs (no redraw of what the user may be pointing at). */
function setHtml(el, html) {
  if (el.dataset.html !== html) { el.innerHTML = html; el.dataset.html = html; }
}

export default {
  id: "recordings",
  title: "Recordings",
  size: [1, 2],
  create(body, ctx) {
    body.innerHTML = `<div class="rec-controls">
        <input class="rec-name" placeholder="name (optional)" size="12" aria-label="recording name">
        <button class="rec-start" type="button">● record</button>
        <button class="rec-stop" type="button" disabled>■ stop</button>
        <button class="rec-mark" type="button" disabled>bookmark</button>
      </div>
      <div class="rec-status"></div><div class="rec-error bad" hidden></div>
      <table class="grid-table rec-files"><thead><tr><th>file</th><th></th></tr></thead>
      <tbody></tbody></table>`;
    const $ = (sel) => body.querySelector(sel);
    const errorEl = $(".rec-error");
    let replaying = null; // the open replay's status, or null
    const rows = new Map(); // file name -> its <tr>, kept while the file's row reads the same
    function fail(err) { errorEl.hidden = false; errorEl.textContent = err.message; }
    async function act(method, path, payload) {
      errorEl.hidden = true;
      try { await api(method, path, payload); } catch (err) { fail(err); }
      refresh();
    }
    $(".rec-start").addEventListener("click", () => act("POST", "api/recordings/start", { name: $(".rec-name").value }));
    $(".rec-stop").addEventListener("click", () => act("POST", "api/recordings/stop"));
    $(".rec-mark").addEventListener("click", async () => {
      errorEl.hidden = true;
      if (replaying) { // a note on the open log, at its position
        const name = prompt("bookmark name (at the replay's position)", `note ${clock(replaying.position_s)}`);
        if (!name) return;
        try {
          await api("POST", "api/replay/bookmark", { name });
          ctx.store.emit("replay-bookmarked", name);
        } catch (err) { fail(err); }
        return;
      }
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

    function showFiles(files) {
      const tbody = $(".rec-files tbody");
      const wanted = files.map((f) => {
        const html = fileRow(f);
        let tr = rows.get(f.name);
        if (!tr) {
          tr = document.createElement("tr");
          tr.dataset.file = f.name;
          rows.set(f.name, tr);
        }
        setHtml(tr, html);
        return tr;
      });
      for (const name of [...rows.keys()]) if (!files.some((f) => f.name === name)) rows.delete(name);
      if (!wanted.length) {
        setHtml(tbody, `<tr><td colspan="2" class="empty">no recordings yet</td></tr>`);
        return;
      }
      const have = [...tbody.children];
      if (have.length !== wanted.length || have.some((tr, i) => tr !== wanted[i])) {
        tbody.replaceChildren(...wanted);
        delete tbody.dataset.html;
      }
    }

    /** The recorder process beside the dashboard: down (its spare takes over), a disk error, the gaps it left. */
    function recorderBanner(process, listing) {
      const error = process?.error || listing.manual?.error || listing.match?.error || "";
      let html = error ? `<div class="rec-banner bad" role="alert">recording: ${esc(error)}</div>` : "";
      if (process && !process.up) {
        const since = process.down_since ? ` for ${Math.max(0, Date.now() / 1000 - process.down_since).toFixed(1)} s` : "";
        html += `<div class="rec-banner bad" role="alert">the recorder does not answer${since}: it is restarted, the recording will have a gap</div>`;
      } else if (process?.outages?.length) {
        const gaps = process.outages.map((o) => `${o.down_s.toFixed(2)} s`).join(", ");
        html += `<div class="rec-banner warn">the recorder was restarted (gaps of ${esc(gaps)}, bookmarked "recording gap" on the timeline)</div>`;
      }
      return html;
    }

    async function refresh() {
      let listing;
      try {
        const [files, replay] = await Promise.all([api("GET", "api/recordings"), api("GET", "api/replay").catch(() => null)]);
        listing = files;
        replaying = replay && !["closed", "loading"].includes(replay.state) ? replay : null;
      } catch (err) { fail(err); return; }
      setHtml($(".rec-status"), recorderBanner(listing.process, listing) + (running(listing.manual, "manual") +
        running(listing.match, "match") ||
        `<div class="empty">not recording${listing.auto_match ? " (matches are recorded automatically)" : ""}</div>`));
      $(".rec-start").disabled = !!listing.manual;
      $(".rec-stop").disabled = !listing.manual;
      const mark = $(".rec-mark");
      mark.disabled = !replaying && !listing.manual && !listing.match;
      mark.textContent = replaying ? "bookmark replay" : "bookmark";
      mark.title = replaying ? "a named bookmark on the replayed log at its position (kept beside the log)"
        : "mark this moment in the running recordings";
      showFiles(listing.files);
    }
    refresh();
    const timer = setInterval(refresh, 2000);
    const offs = [ctx.store.on("replay-opened", refresh), ctx.store.on("replay-closed", refresh)];
    return { destroy() { clearInterval(timer); offs.forEach((off) => off()); } };
  },
};
