// Replay: open a log, see what is in it (robots, topics, counts), and plot any numeric field of any replayed topic
// (joints by name; topics panels do not know, e.g. from another team's ROS 2 bag). The timeline, play/pause/seek,
// speed and close are the playback bar's (web/playback_bar.js), fixed at the window's bottom while a log is open.
// Replayed robots are robots of their own (replay.<id>), so live robots go on beside them unchanged.

import { api, numericFields } from "../lab_api.js";
import { esc } from "../dom.js";
import { clock } from "../playback_bar.js";

const PLOT_POINTS = 400;

function valueAt(data, path) {
  return path.split("/").reduce((v, key) => (v === undefined || v === null ? undefined : v[key]), data);
}

export default {
  id: "replay",
  title: "Replay",
  size: [2, 2], // two rows: the plot fits below the controls (one row cut it off)
  create(body, ctx) {
    body.innerHTML = `<div class="replay">
      <div class="replay-controls">
        <input class="replay-path" placeholder="recording name or path of an .mcap" size="28" aria-label="log file">
        <button class="replay-open" type="button">open</button>
        <span class="replay-state badge">closed</span>
        <span class="replay-summary"></span>
      </div>
      <progress class="replay-progress" max="1" value="0" hidden></progress>
      <div class="replay-error bad" hidden></div>
      <details class="replay-topics"><summary>topics</summary><table class="grid-table"><thead><tr><th>robot</th>
        <th>topic</th><th>type</th><th>messages</th></tr></thead><tbody></tbody></table></details>
      <div class="replay-plot-controls"><label>plot <select class="replay-plot-topic"><option value="">topic…</option></select></label>
        <select class="replay-plot-field" aria-label="field"><option value="">field…</option></select></div>
      <canvas class="replay-plot" height="120"></canvas>
    </div>`;
    const $ = (sel) => body.querySelector(sel);
    const errorEl = $(".replay-error");
    let info = null;
    let status = { state: "closed" };
    let plot = { topic: "", robot: "", field: "", label: "", off: null, points: [], lastFrame: null };

    function fail(err) { errorEl.hidden = false; errorEl.textContent = err.message; }

    $(".replay-open").addEventListener("click", async () => {
      errorEl.hidden = true;
      const poll = setInterval(refresh, 200); // the progress bar while the server scans the file
      const name = $(".replay-path").value.trim();
      try { await api("POST", "api/replay/open", { path: name }); await loadInfo(); ctx.store.emit("replay-opened", name); }
      catch (err) { fail(err); }
      clearInterval(poll);
      refresh();
    });
    $(".replay-plot-topic").addEventListener("change", (e) => choosePlot(e.target.value));
    $(".replay-plot-field").addEventListener("change", (e) => {
      plot.field = e.target.value;
      plot.label = e.target.selectedOptions[0]?.textContent ?? plot.field;
      plot.points = [];
    });
    const offOpened = ctx.store.on("replay-opened", async (name) => { $(".replay-path").value = name; await loadInfo(); refresh(); });

    function choosePlot(key) {
      plot.off?.();
      const [robot, topic] = key.split("|");
      plot = { topic, robot, field: "", label: "", off: null, points: [], lastFrame: null };
      $(".replay-plot-field").innerHTML = '<option value="">field…</option>';
      if (!topic) return;
      const release = ctx.conn.subscribe(robot, topic, 30);
      const off = ctx.store.on(`topic:${topic}`, (frame) => {
        if (frame.robot !== robot || frame.type !== "msg") return;
        if (!plot.lastFrame) showFields(plot);
        plot.lastFrame = frame;
        if (!plot.field) return;
        const v = valueAt(frame.data, plot.field);
        if (typeof v !== "number") return;
        if (plot.points.length && frame.stamp < plot.points[plot.points.length - 1][0]) plot.points = []; // a seek back
        plot.points.push([frame.stamp, v]);
        if (plot.points.length > PLOT_POINTS) plot.points.shift();
      });
      plot.off = () => { off(); release(); };
    }

    /** The numeric fields the server lists for the plotted topic (asked once its first message is there), by name:
     * a joint's position reads "position/RKnee", not "position/2". */
    async function showFields(chosen) {
      let fields = [];
      try { fields = await numericFields(chosen.robot, chosen.topic); } catch (err) { fail(err); }
      if (plot !== chosen) return; // another topic was chosen meanwhile
      $(".replay-plot-field").innerHTML = '<option value="">field…</option>' +
        fields.map((f) => `<option value="${esc(f.path)}" title="${esc(f.path)}">${esc(f.name ?? f.label)}</option>`).join("");
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
      $(".replay-summary").textContent = info ? `${info.robots.join(", ")}: ${clock(info.duration_s)}, ` +
        `${info.messages} messages, ${info.bookmarks.length} bookmarks` : "";
    }

    function render() {
      $(".replay-state").textContent = status.state;
      $(".replay-state").className = `replay-state badge ${status.state === "playing" ? "ok" : status.state === "closed" ? "" : "warn"}`;
      const progress = $(".replay-progress");
      progress.hidden = status.state !== "loading";
      progress.value = status.progress ?? 0;
      if (status.state === "closed") { info = null; $(".replay-summary").textContent = ""; }
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
        const x = ((t - t0) / Math.max(t1 - t0, 1e-9)) * (w - 4) + 2, y = h - 4 - ((v - lo) / (hi - lo)) * (h - 18) - 2;
        if (i) g.lineTo(x, y); else g.moveTo(x, y);
      });
      g.stroke();
      g.fillStyle = getComputedStyle(body).color;
      g.fillText(`${plot.robot} ${plot.label}: ${pts[pts.length - 1][1].toPrecision(4)} [${lo.toPrecision(3)}, ${hi.toPrecision(3)}]`, 4, 10);
    }

    async function refresh() {
      try { status = await api("GET", "api/replay"); } catch { return; }
      if (status.state !== "closed" && status.state !== "loading" && (!info || info.path !== status.path)) await loadInfo();
      render();
    }
    refresh();
    const timer = setInterval(refresh, 1000);
    const drawTimer = setInterval(drawPlot, 200);
    return {
      destroy() { clearInterval(timer); clearInterval(drawTimer); offOpened(); plot.off?.(); },
      resize: drawPlot,
    };
  },
};
