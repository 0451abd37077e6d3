// Link health: one line per robot, how well its data reaches this laptop (the server's per-stream figures,
// over telemetry in a match): status, age, streams that went stale or lost, worst loss, messages/s, budget used.

import { esc } from "../dom.js";

export default {
  id: "links",
  title: "Link health",
  size: [2, 1],
  create(body, ctx) {
    const { store, config } = ctx;
    body.innerHTML = `<table class="grid-table link-table"><thead><tr><th>robot</th><th>status</th><th>age s</th>
      <th>streams ok / stale / lost</th><th>worst loss %</th><th>msg/s</th><th>budget %</th></tr></thead>
      <tbody></tbody></table>`;
    const tbody = body.querySelector("tbody");

    function render() {
      if (!store.robots.length) {
        tbody.innerHTML = '<tr><td colspan="7" class="empty">no robot heard yet</td></tr>';
        return;
      }
      tbody.innerHTML = store.robots.map((info) => {
        const age = store.robotAge(info);
        const status = age >= config.lost_after_s ? "lost" : age >= config.stale_after_s ? "stale" : "ok";
        const counts = { ok: 0, stale: 0, lost: 0, event: 0 };
        let loss = null, rate = 0, share = null;
        for (const [topic, s] of Object.entries(info.streams)) {
          counts[store.streamHealth(info, topic, config.stale_after_s, config.lost_after_s)]++;
          if (s.loss_pct !== undefined) loss = Math.max(loss ?? 0, s.loss_pct);
          if (s.budget_share !== undefined) share = (share ?? 0) + s.budget_share;
          rate += s.rate_hz;
        }
        const cls = status === "ok" ? (counts.lost ? "warn" : "") : status === "stale" ? "warn" : "bad";
        return `<tr class="${cls}" data-robot="${esc(info.robot)}" data-status="${status}">
          <td>${esc(info.robot)}</td><td>${status.toUpperCase()}</td><td>${age.toFixed(1)}</td>
          <td>${counts.ok + counts.event} / ${counts.stale} / ${counts.lost}</td>
          <td>${loss === null ? "–" : loss.toFixed(1)}</td><td>${rate.toFixed(0)}</td>
          <td>${share === null ? "–" : (100 * share).toFixed(0)}</td></tr>`;
      }).join("");
    }

    const offs = [store.on("robots", render)];
    const timer = setInterval(render, 1000); // ages advance even when nothing arrives
    render();
    return { destroy() { clearInterval(timer); offs.forEach((off) => off()); } };
  },
};
