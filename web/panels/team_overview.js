// Team overview: a card per robot with HCM state, penalty, game state, battery, hottest servo and link health.

import { gameName, hcmName, hcmStateIsBad, hcmStateIsPenalty } from "../msgtypes.js";
import { esc } from "../dom.js";

const TOPICS = [["robot_state", 5], ["gamestate", 2], ["servo_data", 1], ["overview", 5]];
const ROW_CLASS = { ok: "", event: "event-row", stale: "stale-row", lost: "lost-row" };
const EVENT_TITLE = "sent only when something happens: silence is normal";

/** The card's facts from whatever arrived: full topics (live) or the compact overview (telemetry). */
export function robotFacts(store, robot) {
  const overview = store.get(robot, "overview")?.data;
  const state = store.get(robot, "robot_state")?.data?.state ?? overview?.hcm_state;
  const game = store.get(robot, "gamestate")?.data;
  const servo = store.get(robot, "servo_data")?.data;
  let voltage = overview?.battery_voltage ?? null;
  let hottest = overview?.hottest_servo ? `${overview.hottest_servo} ${overview.hottest_servo_temperature?.toFixed(0)} °C`
    : null;
  if (servo) {
    if (servo.voltage?.length) voltage = servo.voltage.reduce((a, b) => a + b, 0) / servo.voltage.length;
    let best = null;
    for (const t of servo.temperature || []) {
      if (t.temperature !== null && (!best || t.temperature > best.temperature)) best = t;
    }
    if (best) hottest = `${best.header.frame_id || "?"} ${best.temperature.toFixed(0)} °C`;
  }
  const penalized = Boolean(game?.penalized || overview?.penalized || hcmStateIsPenalty(state));
  const gameState = game ? game.game_state : (overview?.gamestate_known ? overview.game_state : undefined);
  return { state, penalized, gameState, voltage, hottest };
}

export default {
  id: "team",
  title: "Team overview",
  size: [3, 2],
  create(body, ctx) {
    const { store, config } = ctx;
    for (const [topic, hz] of TOPICS) ctx.conn.subscribe("*", topic, hz);
    const cards = document.createElement("div");
    cards.className = "cards";
    body.append(cards);
    cards.addEventListener("click", (e) => {
      const card = e.target.closest(".card");
      if (card) store.setFocus(card.dataset.robot);
    });

    function render() {
      const infos = new Map(store.robots.map((r) => [r.robot, r]));
      const ids = store.robotIds();
      if (!ids.length) {
        cards.innerHTML = '<div class="empty">no robot heard yet</div>';
        return;
      }
      cards.innerHTML = ids.map((id) => card(id, infos.get(id))).join("");
    }

    function card(id, info) {
      const age = info ? store.robotAge(info) : Infinity;
      const status = age >= config.lost_after_s ? "lost" : age >= config.stale_after_s ? "stale" : "ok";
      const f = robotFacts(store, id);
      const stateClass = f.state === undefined ? "" : hcmStateIsBad(f.state) ? "bad" : "ok";
      const streams = info ? Object.entries(info.streams) : [];
      const rows = streams.map(([topic, s]) => {
        const sAge = store.robotAge(info, topic);
        const health = store.streamHealth(info, topic, config.stale_after_s, config.lost_after_s);
        const loss = s.loss_pct === undefined ? "–" : `${s.loss_pct.toFixed(1)}`;
        const share = s.budget_share === undefined ? "–" : `${(100 * s.budget_share).toFixed(0)}`;
        const ageAttrs = health === "event" ? ` style="color: var(--muted)" title="${EVENT_TITLE}"` : "";
        return `<tr class="${ROW_CLASS[health]}" data-topic="${esc(topic)}" data-health="${health}">
          <td>${esc(topic)}</td><td${ageAttrs}>${sAge.toFixed(1)}</td><td>${loss}</td>
          <td>${s.rate_hz.toFixed(1)}</td><td>${share}</td></tr>`;
      }).join("");
      const label = status === "ok" ? "OK" : status === "stale" ? `STALE ${age.toFixed(1)} s` : "LOST";
      const replayed = store.isReplayed(id); // a robot of the open log, never a live one: said on the card
      return `<div class="card ${status} ${id === store.focus ? "focused" : ""} ${replayed ? "replayed" : ""}"
          data-robot="${esc(id)}" data-status="${status}">
        <h3>${replayed ? '<span class="badge replay" title="from the open log, not live">REPLAY</span> ' : ""}${esc(id)}
          <span class="badge ${status === "ok" ? "ok" : status === "stale" ? "warn" : "bad"}">${label}</span></h3>
        <dl class="facts">
          <dt>HCM</dt><dd class="hcm-state ${stateClass}">${esc(hcmName(f.state))}</dd>
          <dt>penalized</dt><dd class="penalized ${f.penalized ? "bad" : ""}">${f.penalized ? "PENALIZED" : "no"}</dd>
          <dt>game</dt><dd class="game-state">${esc(gameName(f.gameState))}</dd>
          <dt>battery</dt><dd>${f.voltage === null ? "–" : `${f.voltage.toFixed(1)} V`}</dd>
          <dt>hottest servo</dt><dd>${f.hottest === null ? "–" : esc(f.hottest)}</dd>
        </dl>
        <table><tr><th>stream</th><th>age s</th><th>loss %</th><th>Hz</th><th>budget %</th></tr>${rows}</table>
      </div>`;
    }

    const offs = [store.on("robots", render), store.on("focus", render)];
    const timer = setInterval(render, 500); // ages advance even when nothing arrives
    render();
    return { destroy() { clearInterval(timer); offs.forEach((off) => off()); } };
  },
};
