// ROS 2 robots: every robot the liveliness tokens show in the listened domains, each topic it publishes, and
// whether the dashboard shows it (on which panel topic) or why not: "definition missing" (give the team's
// interfaces with --ros-interfaces), a type hash that does not match. Asks the server every 2 s while open.

import { esc } from "../dom.js";
import { ros2Rows, ros2Summary } from "../models/ros2_topics.js";

const PERIOD_MS = 2000;

export default {
  id: "ros2",
  title: "ROS 2 robots",
  size: [2, 1],
  create(body) {
    body.innerHTML = `<div class="ros2-summary empty">asking the dashboard...</div>
      <table class="grid-table ros2-table"><thead><tr><th>robot</th><th>topic</th><th>type</th><th>status</th>
      <th>panel topic</th></tr></thead><tbody></tbody></table>`;
    const summary = body.querySelector(".ros2-summary");
    const tbody = body.querySelector("tbody");
    let stopped = false;

    async function refresh() {
      try {
        const reply = await fetch("api/ros2/robots");
        if (!reply.ok) throw new Error(`HTTP ${reply.status}`);
        const answer = await reply.json();
        if (stopped) return;
        summary.textContent = ros2Summary(answer);
        tbody.innerHTML = ros2Rows(answer).map((row) => `<tr class="${row.shown ? "" : "warn"}"
          data-robot="${esc(row.robot)}" data-topic="${esc(row.topic)}" data-status="${esc(row.status)}">
          <td>${esc(row.robot)} <span class="muted">(${row.domain})</span></td><td>${esc(row.topic)}</td>
          <td>${esc(row.type)}</td><td>${esc(row.status)}</td><td>${esc(row.panel)}</td></tr>`).join("");
      } catch (err) {
        if (!stopped) summary.textContent = `cannot ask the dashboard: ${err.message}`;
      }
    }

    refresh();
    const timer = setInterval(refresh, PERIOD_MS);
    return { destroy() { stopped = true; clearInterval(timer); } };
  },
};
