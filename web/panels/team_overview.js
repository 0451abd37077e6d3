// Team overview: the robots grouped by team (the colour their GameController gives them), a card each in a grid:
// number, role, HCM state, penalty with the seconds left, game state, battery, hottest servo, link health, and whom
// it hears over team communication (age and loss of each teammate's messages, and how many messages a second it sends
// itself); with an HSL GameController each team's heading shows the team messages it may still send. Its streams'
// table folds away when the cards must be small (more than two robots).

import { gameName, hcmName, hcmStateIsBad, hcmStateIsPenalty } from "../msgtypes.js";
import { esc } from "../dom.js";
import { penaltyText, playerNumber, roleOf, teamsOf } from "../teams.js";

const TOPICS = [["robot_state", 5], ["gamestate", 2], ["servo_data", 1], ["overview", 5], ["strategy", 2],
  ["team_comm", 1]];
const ROW_CLASS = { ok: "", event: "event-row", stale: "stale-row", lost: "lost-row" };
const EVENT_TITLE = "sent only when something happens: silence is normal";
const OPEN_STREAMS_UP_TO = 2; // robots: with more, each card's streams table starts folded
const MATE_STALE_S = 2; // a teammate not heard this long is shown stale (the mitecom node's teammate timeout)
const MATE_LOSS_WARN = 20; // % of its messages missing
const BUDGET_TITLE = "team messages left (the GameController's budget)";

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
  const penalty = penaltyText(game) || (penalized ? "PENALIZED" : "");
  return { state, penalized, penalty, gameState, voltage, hottest };
}

/** What the robot sends over team communication: {rateHz, allowedHz} (allowedHz null: no budget to keep), null if
 * its team_comm does not say (an older robot) or it has sent nothing in the last 10 s. */
export function ownSending(store, robot) {
  const status = store.get(robot, "team_comm")?.data;
  if (!status || !(status.send_rate_hz > 0)) return null;
  return { rateHz: status.send_rate_hz, allowedHz: status.budget_rate_hz >= 0 ? status.budget_rate_hz : null };
}

/** Whom the robot hears over team communication: [{mate, age, loss, received}] (its team_comm), null if unknown. */
export function teammatesHeard(store, robot) {
  const status = store.get(robot, "team_comm")?.data;
  if (!status) return null;
  return status.mate_ids.map((mate, i) => ({ mate, age: status.age[i], loss: status.loss_pct[i],
    received: status.received[i] }));
}

export default {
  id: "team",
  title: "Team overview",
  size: [3, 2],
  create(body, ctx) {
    const { store, config } = ctx;
    const releases = TOPICS.map(([topic, hz]) => ctx.conn.subscribe("*", topic, hz));
    const root = document.createElement("div");
    root.className = "teams";
    body.append(root);
    const folded = new Map(); // robot -> whether its streams table is open, once the user chose
    root.addEventListener("click", (e) => {
      const target = /** @type {HTMLElement} */ (e.target);
      const card = /** @type {HTMLElement | null} */ (target.closest(".card"));
      if (!card) return;
      const summary = target.closest("summary");
      if (summary) folded.set(card.dataset.robot, !(/** @type {HTMLDetailsElement} */ (summary.parentElement)).open); // the click opens or closes it
      else store.setFocus(card.dataset.robot);
    });

    function render() {
      const infos = new Map(store.robots.map((r) => [r.robot, r]));
      const ids = store.robotIds();
      if (!ids.length) {
        root.innerHTML = '<div class="empty">no robot heard yet</div>';
        return;
      }
      const teams = teamsOf(store, ids);
      const perRow = Math.max(2, ...teams.map((t) => t.robots.length));
      root.style.setProperty("--per-row", String(Math.min(perRow, 6)));
      root.innerHTML = teams.map((team) => `<section class="team" data-team="${esc(team.name)}">
          <h4><span class="swatch" style="background:${esc(team.css)}"></span>${esc(team.name)}
          ${team.score === undefined ? "" : `<span class="team-score">${team.score}</span>`}
          ${team.kickOff ? '<span class="badge">kick-off</span>' : ""}
          ${team.budget === undefined ? "" : `<span class="team-budget" title="${BUDGET_TITLE}">${
            team.budget.toLocaleString("en")} msgs left</span>`}</h4>
          <div class="cards">${team.robots.map((id) => card(id, infos.get(id), ids.length)).join("")}</div>
        </section>`).join("");
    }

    function card(id, info, robots) {
      const age = info ? store.robotAge(info) : Infinity;
      const status = age >= config.lost_after_s ? "lost" : age >= config.stale_after_s ? "stale" : "ok";
      const f = robotFacts(store, id);
      const stateClass = f.state === undefined ? "" : hcmStateIsBad(f.state) ? "bad" : "ok";
      const streams = info ? Object.entries(info.streams) : [];
      /** @type {number | null} */
      let worstLoss = null;
      const rows = streams.map(([topic, s]) => {
        const sAge = store.robotAge(info, topic);
        const health = store.streamHealth(info, topic, config.stale_after_s, config.lost_after_s);
        if (s.loss_pct !== undefined) worstLoss = Math.max(worstLoss ?? 0, s.loss_pct);
        const loss = s.loss_pct === undefined ? "–" : `${s.loss_pct.toFixed(1)}`;
        const share = s.budget_share === undefined ? "–" : `${(100 * s.budget_share).toFixed(0)}`;
        const ageAttrs = health === "event" ? ` style="color: var(--muted)" title="${EVENT_TITLE}"` : "";
        return `<tr class="${ROW_CLASS[health]}" data-topic="${esc(topic)}" data-health="${health}">
          <td>${esc(topic)}</td><td${ageAttrs}>${sAge.toFixed(1)}</td><td>${loss}</td>
          <td>${s.rate_hz.toFixed(1)}</td><td>${share}</td></tr>`;
      }).join("");
      const label = status === "ok" ? "OK" : status === "stale" ? `STALE ${age.toFixed(1)} s` : "LOST";
      const replayed = store.isReplayed(id); // a robot of the open log, never a live one: said on the card
      const number = playerNumber(store, id);
      const role = roleOf(store, id);
      const open = folded.get(id) ?? robots <= OPEN_STREAMS_UP_TO;
      const link = `${label}${worstLoss === null ? "" : ` · loss ${worstLoss.toFixed(0)} %`}`;
      return `<div class="card ${status} ${id === store.focus ? "focused" : ""} ${replayed ? "replayed" : ""}"
          data-robot="${esc(id)}" data-status="${status}">
        <h3>${number === undefined ? "" : `<span class="number">#${number}</span>`}
          ${replayed ? '<span class="badge replay" title="from the open log, not live">REPLAY</span>' : ""}
          <span class="robot-id" title="${esc(id)}">${esc(id)}</span>
          <span class="badge ${status === "ok" ? "ok" : status === "stale" ? "warn" : "bad"}">${label}</span></h3>
        <dl class="facts">
          <dt>role</dt><dd class="role" title="${esc(role)}">${role ? esc(role) : "–"}</dd>
          <dt>HCM</dt><dd class="hcm-state ${stateClass}" title="${esc(hcmName(f.state))}">${esc(hcmName(f.state))}</dd>
          <dt>penalized</dt><dd class="penalized ${f.penalized ? "bad" : ""}" title="${f.penalty}">${f.penalty || "no"}</dd>
          <dt>game</dt><dd class="game-state" title="${esc(gameName(f.gameState))}">${esc(gameName(f.gameState))}</dd>
          <dt>battery</dt><dd>${f.voltage === null ? "–" : `${f.voltage.toFixed(1)} V`}</dd>
          <dt>hottest</dt><dd class="hottest" title="${esc(f.hottest ?? "")}">${f.hottest === null ? "–" : esc(f.hottest)}</dd>
          <dt>link</dt><dd class="link">${esc(link)}</dd>
        </dl>
        ${hears(id)}
        <details class="streams" ${open ? "open" : ""}><summary>streams</summary>
          <table><tr><th>stream</th><th>age s</th><th>loss %</th><th>Hz</th><th>budget %</th></tr>${rows}</table>
        </details>
      </div>`;
    }

    /** One chip per teammate the robot hears: its number, the age of its newest message, the loss. */
    function hears(id) {
      const mates = teammatesHeard(store, id);
      if (mates === null) return "";
      const chips = mates.map(({ mate, age, loss }) => {
        const cls = age >= MATE_STALE_S ? "bad" : loss >= MATE_LOSS_WARN ? "warn" : "ok";
        const ageText = Number.isFinite(age) ? `${age.toFixed(1)} s` : "never";
        return `<span class="mate ${cls}" data-mate="${mate}" title="teammate #${mate}: newest message ${ageText} ago, ${
          loss.toFixed(0)} % of its messages missing">#${mate} ${ageText} ${loss.toFixed(0)}%</span>`;
      }).join("");
      const own = ownSending(store, id);
      const allows = own === null || own.allowedHz === null ? "" : `; the budget allows ${own.allowedHz.toFixed(2)}`;
      const sends = own === null ? "" : `<span class="sends" title="team messages sent per second over the last 10 s${
        allows}">sends ${own.rateHz.toFixed(1)}/s</span>`;
      return `<div class="hears" data-heard="${mates.length}"><span class="label">hears</span>${
        chips || '<span class="mate bad">nobody</span>'}${sends}</div>`;
    }

    const offs = [store.on("robots", render), store.on("focus", render), ...releases];
    const timer = setInterval(render, 500); // ages advance even when nothing arrives
    render();
    return { destroy() { clearInterval(timer); offs.forEach((off) => off()); } };
  },
};
