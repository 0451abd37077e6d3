// 3D robot: viser's own client (served by the server's viser instance) in an iframe.

export default {
  id: "robot3d",
  title: "3D robot",
  size: [1, 2],
  create(body, ctx) {
    const port = ctx.config.robot3d_port;
    if (!port) {
      body.innerHTML = '<div class="empty">3D view is off (start the server with --robot3d)</div>';
      return {};
    }
    const frame = document.createElement("iframe");
    frame.title = "3D robot (viser)";
    frame.src = `${location.protocol}//${location.hostname}:${port}/`;
    body.append(frame);
    return {};
  },
};
