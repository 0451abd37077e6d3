// Replay timeline: open a log, play / pause / step, speed 0.1x-10x, seek by clicking the timeline, bookmarks on it,
// a progress bar while an unindexed log is scanned, and a small plot of any numeric field of any replayed topic
// (topics panels do not know, e.g. from another team's ROS 2 bag). Replay feeds the same hub as live data.

import { api, numericFields } from "../lab_api.js";
import { esc } from "../dom.js";

const SPEEDS = [0.1, 0.25, 0.5, 1, 2, 5, 10];
const PLOT_POINTS = 400;

function clock(seconds) {
  const m = Math.floor(seconds / 60);
  return `${m}:${(seconds % 60).toFixed(1).padStart(4, "0")}`;
}

function valueAt(data, path) {
  return path.split("/").reduce((v, key) => (v === undefined || v === null ? undefined : v[key]), data);
}

export default {
  id: "replay",
  title: "Replay",
  size: [2, 1],
  create(body, ctx) {
    body.innerHTML = `<div class="replay">
      <div class="replay-controls">
        <input class="replay-path" placeholder="recording name or path of an .mcap" size="28" aria-label="log file">
        <button class="replay-open" type="button">open</button>
        <button class="replay-play" type="button" disabled>▶ play</button>
        <button class="replay-step" type="button" disabled title="next message">step</button>
        <label>speed <select class="replay-speed">${SPEEDS.map((s) => `<option value="${s}" ${s === 1 ? "selected" : ""}>${s}x</option>`).join("")}</select></label>
        <span class="replay-state badge">closed</span>
        <span class="replay-time"></span>
      </div>
      <progress class="replay-progress" max="1" value="0" hidden></progress>
      <div class="replay-timeline" title="click to seek"><div class="replay-cursor"></div></div>
      <div class="replay-error bad" hidden></div>
      <details class="replay-topics"><summary>topics</summary><table class="grid-table"><thead><tr><th>robot</th>
        <th>topic</th><th>type</th><th>messages</th></tr></thead><tbody></tbody></table></details>
      <div class="replay-plot-controls"><label>plot <select class="replay-plot-topic"><option value="">topic…</option></select></label>
        <select class="replay-plot-field"><option value="">field…</option></select></div>
      <canvas class="replay-plot" height="90"></canvas>
    </div>`;
    const $ = (sel) => body.querySelector(sel);
    const errorEl = $(".replay-error");
    let info = null;
    let status = { state: "closed" };
    let plot = { topic: "", robot: "", field: "", off: null, points: [], lastFrame: null };

    function fail(err) { errorEl.hidden = false; errorEl.textContent = err.message; }
    async function call(path, payload) {
      errorEl.hidden = true;
      try { status = await api("POST", `api/replay/${path}`, payload); render(); } catch (err) { fail(err); }
    }

    $(".replay-open").addEventListener("click", async () => {
      errorEl.hidden = true;
      const poll = setInterval(refresh, 200); // the progress bar while the server scans the file
      try { await api("POST", "api/replay/open", { path: $(".replay-path").value.trim() }); await loadInfo(); }
      catch (err) { fail(err); }
      clearInterval(poll);
      refresh();
    });
    $(".replay-play").addEventListener("click", () => call(status.state === "playing" ? "pause" : "play"));
    $(".replay-step").addEventListener("click", () => call("step", { count: 1 }));
    $(".replay-speed").addEventListener("change", (e) => call("speed", { speed: +e.target.value }));
    $(".replay-timeline").addEventListener("click", (e) => {
      if (!info) return;
      const box = e.currentTarget.getBoundingClientRect();
      call("seek", { t_s: ((e.clientX - box.left) / box.width) * info.duration_s });
      plot.points = [];
    });
    $(".replay-plot-topic").addEventListener("change", (e) => choosePlot(e.target.value));
    $(".replay-plot-field").addEventListener("change", (e) => { plot.field = e.target.value; plot.points = []; });
    const offOpened = ctx.store.on("replay-opened", async (name) => { $(".replay-path").value = name; await loadInfo(); refresh(); });

    function choosePlot(key) {
      plot.off?.();
      const [robot, topic] = key.split("|");
      plot = { topic, robot, field: "", off: null, points: [], lastFrame: null };
      $(".replay-plot-field").innerHTML = '<option value="">field…</option>';
      if (!topic) return;
      ctx.conn.subscribe(robot, topic, 30);
      plot.off = ctx.store.on(`topic:${topic}`, (frame) => {
        if (frame.robot !== robot || frame.type !== "msg") return;
        if (!plot.lastFrame) showFields(plot);
        plot.lastFrame = frame;
        if (!plot.field) return;
        const v = valueAt(frame.data, plot.field);
        if (typeof v === "number") {
          plot.points.push([frame.stamp, v]);
          if (plot.points.length > PLOT_POINTS) plot.points.shift();
        }
      });
    }

    /** The numeric fields the server lists for the plotted topic (asked once its first message is there). */
    async function showFields(chosen) {
      let fields = [];
      try { fields = await numericFields(chosen.robot, chosen.topic); } catch (err) { fail(err); }
      if (plot !== chosen) return; // another topic was chosen meanwhile
      $(".replay-plot-field").innerHTML = '<option value="">field…</option>' +
        fields.map((f) => `<option value="${esc(f.path)}">${esc(f.label)}</option>`).join("");
      $(".replay-plot-field").value = plot.field;
    }

    async function loadInfo() {
      try { info = await api("GET", "api/replay/info"); } catch { info = null; }
      const tbody = $(".replay-topics tbody");
      tbody.innerHTML = info ? info.topics.map((t) => `<tr title="${esc(t.problem)}"><td>${esc(t.robot)}</td>
        <td>${esc(t.topic)}</td><td>${esc(t.msgtype)}${t.decodable ? "" : ' <span class="badge warn">raw</span>'}</td>
        <td>${esc(t.count)}</td></tr>`).join("") : "";
      $(".replay-plot-topic").innerHTML = '<option value="">topic…</option>' + (info ? info.topics
        .filter((t) => t.decodable && t.count).map((t) => `<option value="${esc(t.robot)}|${esc(t.topic)}">${esc(t.robot)} ${esc(t.topic)}</option>`).join("") : "");
      const line = $(".replay-timeline");
      line.querySelectorAll(".replay-mark").forEach((m) => m.remove());
      for (const mark of info?.bookmarks ?? []) {
        const el = document.createElement("div");
        el.className = "replay-mark";
        el.style.left = `${(100 * mark.t_s) / Math.max(info.duration_s, 1e-9)}%`;
        el.title = `${mark.name} (${clock(mark.t_s)})`;
        el.dataset.name = mark.name;
        el.addEventListener("click", (e) => { e.stopPropagation(); call("seek", { t_s: mark.t_s }); });
        line.appendChild(el);
      }
    }

    function render() {
      const open = status.state !== "closed" && status.state !== "loading";
      $(".replay-state").textContent = status.state;
      $(".replay-state").className = `replay-state badge ${status.state === "playing" ? "ok" : open ? "warn" : ""}`;
      $(".replay-play").disabled = !open;
      $(".replay-step").disabled = !open;
      $(".replay-play").textContent = status.state === "playing" ? "❚❚ pause" : "▶ play";
      const progress = $(".replay-progress");
      progress.hidden = status.state !== "loading";
      progress.value = status.progress ?? 0;
      if (open && status.duration_s !== undefined) {
        $(".replay-time").textContent = `${clock(status.position_s)} / ${clock(status.duration_s)}`;
        $(".replay-cursor").style.left = `${(100 * status.position_s) / Math.max(status.duration_s, 1e-9)}%`;
      } else {
        $(".replay-time").textContent = "";
      }
      if (status.speed) $(".replay-speed").value = String(status.speed);
      if (status.error) fail(new Error(status.error));
    }

    function drawPlot() {
      const canvas = $(".replay-plot");
      const w = (canvas.width = canvas.clientWidth || 300);
      const h = canvas.height;
      const g = canvas.getContext("2d");
      g.clearRect(0, 0, w, h);
      const pts = plot.points;
      if (pts.length < 2) return;
      const t0 = pts[0][0], t1 = pts[pts.length - 1][0] || t0 + 1;
      let lo = Math.min(...pts.map((p) => p[1])), hi = Math.max(...pts.map((p) => p[1]));
      if (hi === lo) { hi += 1; lo -= 1; }
      g.strokeStyle = getComputedStyle(body).getPropertyValue("--accent") || "#06c";
      g.lineWidth = 2;
      g.beginPath();
      pts.forEach(([t, v], i) => {
        const x = ((t - t0) / Math.max(t1 - t0, 1e-9)) * (w - 4) + 2, y = h - 4 - ((v - lo) / (hi - lo)) * (h - 8);
        if (i) g.lineTo(x, y); else g.moveTo(x, y);
      });
      g.stroke();
      g.fillStyle = getComputedStyle(body).color;
      g.fillText(`${plot.field}: ${pts[pts.length - 1][1].toPrecision(4)} [${lo.toPrecision(3)}, ${hi.toPrecision(3)}]`, 4, 10);
    }

    async function refresh() {
      try { status = await api("GET", "api/replay"); } catch { return; }
      if (status.state !== "closed" && status.state !== "loading" && (!info || info.path !== status.path)) await loadInfo();
      render();
    }
    refresh();
    const timer = setInterval(refresh, 500);
    const drawTimer = setInterval(drawPlot, 200);
    return {
      destroy() { clearInterval(timer); clearInterval(drawTimer); offOpened(); plot.off?.(); },
      resize: drawPlot,
    };
  },
};
