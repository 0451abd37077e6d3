// Game state: what the GameController says, big enough to read from the bench: state, score (of both teams, by
// colour, when both are heard), clock, half, kick-off, the secondary state (free kick, penalty shoot-out...) and
// which robots are penalized, with the seconds left; with an HSL GameController also whether play is stopped (the
// ball being placed) and the team messages each team has left.

import { fmtClock, gameName, secondaryName } from "../msgtypes.js";
import { teamsOf } from "../teams.js";

export default {
  id: "game",
  title: "Game state",
  size: [1, 1],
  create(body, ctx) {
    const { store } = ctx;
    body.innerHTML = `<div class="game-panel">
      <div class="game-main"><span class="game-name"></span> <span class="game-score"></span></div>
      <div class="game-clock"></div><div class="game-secondary"></div><div class="game-penalized"></div></div>`;
    const $ = (sel) => body.querySelector(sel);

    function render() {
      // during a replay the log's game, else the focused robot's view of it; a replayed game is never mixed with
      // the live one
      const from = store.gameSource();
      const game = from === undefined ? undefined : store.get(from, "gamestate").data;
      body.dataset.state = game ? gameName(game.game_state) : "";
      if (!game) {
        $(".game-name").textContent = "no game state";
        for (const sel of [".game-score", ".game-clock", ".game-secondary", ".game-penalized"]) $(sel).textContent = "";
        return;
      }
      const replay = store.isReplayed(from);
      const robots = store.robotIds().filter((id) => store.isReplayed(id) === replay);
      const teams = teamsOf(store, robots).filter((t) => t.colour !== undefined);
      const both = teams.length === 2;
      $(".game-name").textContent = `${replay ? "REPLAY " : ""}${gameName(game.game_state)}`;
      $(".game-score").textContent = both
        ? `${teams[0].name} ${teams[0].score} : ${teams[1].score} ${teams[1].name}`
        : `${game.own_score} : ${game.rival_score}`;
      const kicking = both ? teams.find((t) => t.kickOff) : null;
      $(".game-clock").textContent = `${fmtClock(game.seconds_remaining)} ${game.first_half ? "1st" : "2nd"} half` +
        (both ? (kicking ? ` · kick-off ${kicking.name}` : "") : `${game.has_kick_off ? " · our kick-off" : ""}`);
      const secondary = game.secondary_state
        ? `${secondaryName(game.secondary_state)} ${fmtClock(game.secondary_seconds_remaining)}` : "";
      const budgets = teams.filter((t) => t.budget !== undefined)
        .map((t) => `${t.name} ${t.budget.toLocaleString("en")} msgs left`);
      $(".game-secondary").textContent = [secondary, game.stopped ? "STOPPED" : "", budgets.join(", ")]
        .filter(Boolean).join(" · ");
      const penalized = robots.filter((id) => store.get(id, "gamestate")?.data?.penalized).map((id) => {
        const left = store.get(id, "gamestate").data.seconds_till_unpenalized;
        return left ? `${id} (${left} s)` : id;
      });
      $(".game-penalized").textContent = penalized.length ? `penalized: ${penalized.join(", ")}` : "nobody penalized";
      $(".game-penalized").classList.toggle("bad", penalized.length > 0);
    }

    const offs = [ctx.subscribe("gamestate", 2, render), store.on("focus", render), store.on("robots", render)];
    render();
    return { destroy() { offs.forEach((off) => off()); } };
  },
};
