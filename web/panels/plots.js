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
    frame.src = `${location.protocol}//${host}:${plots.web_port}/?url=${encodeURIComponent(grpc)}`;
    body.append(frame);
    return {};
  },
};
