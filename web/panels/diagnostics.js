// Diagnostics and log: every node's latest DiagnosticStatus (level, message, values), errors on top and in red.

import { esc } from "../dom.js";
import { diagnosticLevel, diagnosticLevelName } from "../msgtypes.js";

const STALE_MS = 5000; // diagnostics come at 1 Hz: five missed reports and the node counts as silent

export default {
  id: "diagnostics",
  title: "Diagnostics and log",
  size: [2, 2],
  create(body, ctx) {
    const statuses = new Map(); // robot/name -> {robot, status, at}
    const log = [];
    body.innerHTML = `<table class="grid-table"><thead><tr><th>robot</th><th>node</th><th>level</th><th>message</th>
      <th>values</th></tr></thead><tbody></tbody></table><div class="log"></div>`;
    const tbody = body.querySelector("tbody");
    const logEl = body.querySelector(".log");
    let dirty = false;
    const offs = [ctx.subscribe("diagnostics", 0, (frame) => {
      for (const status of frame.data.status) {
        const key = `${frame.robot}/${status.name}`;
        const old = statuses.get(key);
        if (!old || old.status.level !== status.level || old.status.message !== status.message) {
          log.push(`${new Date(frame.stamp * 1000).toLocaleTimeString()} ${frame.robot} ${status.name}: ` +
            `${diagnosticLevelName(status.level)} ${status.message}`);
          if (log.length > 200) log.shift();
        }
        statuses.set(key, { robot: frame.robot, status, at: performance.now() });
      }
      dirty = true;
    })];

    let renders = 0;
    function render() {
      if (!dirty && ++renders % 4) return; // re-check silence every 2 s even without news
      dirty = false;
      const now = performance.now();
      const stale = diagnosticLevel("STALE");
      const rows = [...statuses.values()]
        .map((r) => ({ ...r, level: now - r.at > STALE_MS ? stale : r.status.level }))
        .sort((a, b) => b.level - a.level || a.robot.localeCompare(b.robot) || a.status.name.localeCompare(b.status.name));
      tbody.innerHTML = rows.map(({ robot, status, level }) => `<tr class="level-${esc(level)}" data-node="${esc(status.name)}">
        <td>${esc(robot)}</td><td>${esc(status.name)}</td>
        <td>${level === stale && status.level !== stale ? "STALE (silent)"
          : esc(diagnosticLevelName(status.level))}</td>
        <td>${esc(status.message)}</td>
        <td class="values">${status.values.map((v) => `${esc(v.key)}=${esc(v.value)}`).join(" ")}</td></tr>`).join("");
      logEl.innerHTML = log.slice(-30).reverse().map((l) => `<div>${esc(l)}</div>`).join("");
    }
    const timer = setInterval(render, 500);
    return { destroy() { clearInterval(timer); offs.forEach((off) => off()); } };
  },
};
