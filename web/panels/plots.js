// Plots: the rerun web viewer, fed by the server with downsampled numbers, in an iframe. Above it, any topic can be
// added: the server then plots every numeric field of it too (a tab of its own in the viewer).

import { expose } from "../test_hooks.js";
import { api } from "../lab_api.js";
import { esc } from "../dom.js";

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
    body.classList.add("plots-body");
    body.innerHTML = `<div class="lab-bar plots-bar">
        <label title="plot every numeric field of this topic, of every robot, in a tab of its own">every number of
          <select data-role="topic"></select></label>
        <button data-act="add">plot</button>
        <span data-role="chosen"></span>
        <span class="lab-status" data-role="status"></span>
      </div>`;
    const $ = (sel) => body.querySelector(sel);
    const topicSel = $('[data-role="topic"]');
    const chosenEl = $('[data-role="chosen"]');
    const statusEl = $('[data-role="status"]');
    const state = { chosen: [], allTopics: false, error: "" };
    expose("plots", state);

    function show(status) {
      state.chosen = status.chosen || [];
      state.allTopics = Boolean(status.all_topics);
      chosenEl.innerHTML = state.allTopics ? '<span class="muted">every topic is plotted (--plots-all-topics)</span>'
        : state.chosen.map((c) => `<span class="chip" data-topic="${esc(c.topic)}" data-robot="${esc(c.robot)}">
          ${esc(c.topic)}${c.robot === "*" ? "" : ` (${esc(c.robot)})`}
          <button data-act="remove" title="stop plotting it (what was plotted stays)">×</button></span>`).join("");
    }

    async function choose(robot, topic, plotted) {
      try {
        show(await api("POST", "api/plots/topics", { robot, topic, plotted }));
        state.error = "";
        statusEl.textContent = "";
      } catch (err) {
        state.error = String(err.message);
        statusEl.textContent = state.error;
      }
    }

    function refreshTopics() {
      const topics = [...new Set(ctx.store.robots.flatMap((r) => Object.keys(r.streams)))].sort();
      const html = topics.map((t) => `<option value="${esc(t)}">${esc(t)}</option>`).join("");
      if (topicSel.innerHTML !== html) {
        const keep = topicSel.value;
        topicSel.innerHTML = html;
        if (topics.includes(keep)) topicSel.value = keep;
      }
    }

    $('[data-act="add"]').addEventListener("click", () => { if (topicSel.value) choose("*", topicSel.value, true); });
    chosenEl.addEventListener("click", (e) => {
      const chip = e.target.closest('[data-act="remove"]')?.closest(".chip");
      if (chip) choose(chip.dataset.robot, chip.dataset.topic, false);
    });
    const off = ctx.store.on("robots", refreshTopics);
    refreshTopics();
    api("GET", "api/plots").then(show).catch(() => {});

    // The viewer and its data both come through this server (rerun itself listens on loopback only): the data
    // at rerun's own gRPC path on this origin, as rerun's viewer takes no path before "/proxy". (rerun 0.41 reads a
    // URL with the scheme's default port as its own default, 51234: on port 80 or 443 the plots stay empty.)
    const scheme = location.protocol === "https:" ? "rerun+https" : "rerun+http";
    const port = location.port || (location.protocol === "https:" ? "443" : "80");
    const grpc = `${scheme}://${location.hostname}:${port}/proxy`;
    const frame = document.createElement("iframe");
    frame.title = "plots (rerun)";
    // same origin, and a Content-Security-Policy keeps the viewer from calling out
    frame.src = `${plots.viewer}?url=${encodeURIComponent(grpc)}`;
    body.append(frame);
    return { destroy: off };
  },
};
