// 3D robot: viser's own client in an iframe, framed for a small panel. The server passes viser's page and
// WebSocket through its own origin (robot3d/view/): viser itself listens on loopback only.

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
    clip.append(frame, open);
    body.append(clip);

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
    return { destroy() { observer.disconnect(); } };
  },
};
