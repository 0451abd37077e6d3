// 3D robot: viser's own client in an iframe, framed for a small panel. The server passes viser's page and
// WebSocket through its own origin (robot3d/view/): viser itself listens on loopback only.
// Above the scene, a legend names every robot figure with its kind's colour (live: the URDF's own colours, a
// replayed robot purple, the editor's preview a green ghost, there only while it previews) and shows or hides each.

import { api } from "../lab_api.js";
import { esc } from "../dom.js";

const LEGEND_EVERY_MS = 1000;
const KIND_TEXT = { live: "live", replay: "REPLAY", preview: "preview" };

// Below this width viser switches to its phone layout, whose control sheet covers the scene: render at least
// this wide and scale down to fit the panel.
const MIN_VISER_WIDTH = 640;
// viser pins notifications (e.g. "Software WebGL rendering detected") to its top-left corner; the frame starts
// this far above the panel so they stay out of sight instead of covering the robot.
const NOTICE_PX = 170;

/** Frame geometry (CSS px) for a panel body of width x height: viser's layout size, scale and offset. */
export function frameGeometry(width, height) {
  const viserWidth = Math.max(width, MIN_VISER_WIDTH);
  const scale = width > 0 ? width / viserWidth : 1;
  return { width: viserWidth, height: height / scale + NOTICE_PX, scale, top: -NOTICE_PX * scale };
}

export default {
  id: "robot3d",
  title: "3D robot",
  size: [1, 2],
  create(body, ctx) {
    const view = ctx.config.robot3d;
    if (!view) {
      body.innerHTML = '<div class="empty">3D view is off (start the server with --robot3d)</div>';
      return {};
    }
    const url = view.view;
    const clip = document.createElement("div");
    clip.className = "robot3d-clip";
    clip.style.cssText = "position: relative; width: 100%; height: 100%; overflow: hidden;";
    const frame = document.createElement("iframe");
    frame.title = "3D robot (viser)";
    frame.src = url;
    frame.style.cssText = "position: absolute; left: 0; transform-origin: 0 0; border: 0;";
    const open = document.createElement("a");
    open.href = url;
    open.target = "_blank";
    open.rel = "noopener";
    open.textContent = "open full view";
    open.title = "viser on its own page, with its control panel";
    open.style.cssText = "position: absolute; left: 4px; bottom: 2px; font-size: 11px; opacity: 0.7;";
    const legend = document.createElement("div");
    legend.className = "robot3d-legend";
    legend.setAttribute("aria-label", "robots in the 3D view");
    clip.append(frame, open, legend);
    body.append(clip);

    let shownKey = "";
    async function refreshLegend() {
      let status;
      try { status = await api("GET", "api/robot3d"); } catch { return; }
      const figures = status.figures ?? [];
      const key = JSON.stringify(figures);
      if (key === shownKey) return; // unchanged: the checkbox under the pointer stays
      shownKey = key;
      legend.innerHTML = figures.map((f) => `<label class="figure ${esc(f.kind)}" data-figure="${esc(f.name)}"
        title="${esc(f.name)}: ${esc(KIND_TEXT[f.kind] ?? f.kind)}; untick to hide it in the 3D view">
        <input type="checkbox" ${f.visible ? "checked" : ""} ${ctx.config.control ? "" : "disabled"}>
        <span class="swatch" style="background: ${f.color ? esc(f.color) : "var(--muted)"}"></span>${esc(f.name)}
        ${f.kind === "live" ? "" : `<span class="badge ${f.kind === "replay" ? "replay" : "ok"}">${esc(KIND_TEXT[f.kind])}</span>`}
        </label>`).join("");
    }
    legend.addEventListener("change", async (e) => {
      const box = /** @type {HTMLInputElement} */ (e.target);
      const name = /** @type {HTMLElement | null} */ (box.closest("[data-figure]"))?.dataset.figure;
      if (name === undefined) return;
      try { await api("POST", "api/robot3d/visible", { name, visible: box.checked }); } catch { /* refreshed below */ }
      shownKey = "";
      refreshLegend();
    });
    refreshLegend();
    const legendTimer = setInterval(refreshLegend, LEGEND_EVERY_MS);

    function fit() {
      const g = frameGeometry(clip.clientWidth, clip.clientHeight);
      frame.style.width = `${g.width}px`;
      frame.style.height = `${g.height}px`;
      frame.style.top = `${g.top}px`;
      frame.style.transform = `scale(${g.scale})`;
    }
    const observer = new ResizeObserver(fit);
    observer.observe(clip);
    fit();
    return { destroy() { observer.disconnect(); clearInterval(legendTimer); } };
  },
};
