// Plots: the rerun web viewer, fed by the server with downsampled numbers, in an iframe.

export default {
  id: "plots",
  title: "Plots",
  size: [3, 2],
  create(body, ctx) {
    const plots = ctx.config.plots;
    if (!plots) {
      body.innerHTML = '<div class="empty">plots are off (start the server with --plots)</div>';
      return {};
    }
    const host = location.hostname;
    const grpc = `rerun+http://${host}:${plots.grpc_port}/proxy`;
    const frame = document.createElement("iframe");
    frame.title = "plots (rerun)";
    // through the server: same origin, and a Content-Security-Policy keeps the viewer from calling out
    frame.src = `/plots/viewer/index.html?url=${encodeURIComponent(grpc)}`;
    body.append(frame);
    return {};
  },
};
