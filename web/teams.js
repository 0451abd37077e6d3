// The teams on the field as the robots tell them: which team a robot plays in (the colour its GameController gives
// its team, from gamestate), its number and role, the team's score and kick-off, and the ball as the team sees it
// (every teammate's seen ball, weighted by confidence). The team overview, the field view and the game state panel
// share this one reading.

import { constantNames } from "./msgtypes.js";

const STRATEGY = "humanoid_league_msgs/msg/Strategy";
/** GameController team colours (HL v12 TeamInfo.teamColour): name and how the page draws them. */
export const TEAM_COLOURS = [
  { name: "blue", css: "#1f5cff" }, { name: "red", css: "#e0105a" }, { name: "yellow", css: "#f2d40f" },
  { name: "black", css: "#111111" }, { name: "white", css: "#f7f7f7" }, { name: "green", css: "#1aa33a" },
  { name: "orange", css: "#ff8c1a" }, { name: "purple", css: "#8c33cc" }, { name: "brown", css: "#80501a" },
  { name: "gray", css: "#8c8c8c" },
];
const SEEN_BALL_MAX_AGE_S = 2; // a ball seen longer ago is not what the team knows now

/** {name, css} of a team colour number (a number beyond the list: "colour N", grey). */
export function teamColour(colour) {
  return TEAM_COLOURS[colour] ?? { name: `colour ${colour}`, css: "#8c8c8c" };
}

/** The colour number of the robot's team, undefined before its first gamestate. */
export function teamOf(store, robot) {
  return store.get(robot, "gamestate")?.data?.team_color;
}

/** The robot's player number: as its team communication says, else the digits its id ends in. */
export function playerNumber(store, robot) {
  const told = store.get(robot, "team_comm")?.data?.player_id;
  if (told !== undefined) return told;
  const digits = /(\d+)$/.exec(robot);
  return digits ? Number(digits[1]) : undefined;
}

/** The robot's role as its behaviour tells it (Strategy), "" before it does. */
export function roleOf(store, robot) {
  const role = store.get(robot, "strategy")?.data?.role;
  return role === undefined ? "" : (constantNames(STRATEGY, "ROLE_").get(role) ?? `role ${role}`).toLowerCase();
}

const BUDGET_UNKNOWN = 65535; // GameState.MESSAGE_BUDGET_UNKNOWN
const FIRST_BUDGET_VERSION = 19; // the HSL GameController (struct v19 on) keeps a team-message budget

/** The team messages a team may still send, as its GameController reports it; undefined without a budget (HL v12). */
export function messageBudget(game) {
  if (!game || !(game.version >= FIRST_BUDGET_VERSION) || game.message_budget === BUDGET_UNKNOWN) return undefined;
  return game.message_budget;
}

/** The teams heard: [{colour, name, css, robots, score, kickOff, budget}] by colour number; robots without a
 * gamestate yet in a last group of colour undefined. */
export function teamsOf(store, robots = store.robotIds()) {
  const byColour = new Map();
  for (const robot of robots) {
    const colour = teamOf(store, robot);
    if (!byColour.has(colour)) byColour.set(colour, []);
    byColour.get(colour).push(robot);
  }
  const colours = [...byColour.keys()].sort((a, b) => (a ?? 99) - (b ?? 99));
  return colours.map((colour) => {
    const members = byColour.get(colour).sort((a, b) => (playerNumber(store, a) ?? 99) - (playerNumber(store, b) ?? 99)
      || a.localeCompare(b));
    const game = members.map((r) => store.get(r, "gamestate")?.data).find((g) => g);
    const { name, css } = colour === undefined ? { name: "no team yet", css: "#8c8c8c" } : teamColour(colour);
    return { colour, name, css, robots: members, score: game?.own_score, kickOff: Boolean(game?.has_kick_off),
      budget: messageBudget(game) };
  });
}

/** "PENALIZED 23 s" (or without seconds for a penalty without an end), "" when not penalised. */
export function penaltyText(game) {
  if (!game?.penalized) return "";
  return game.seconds_till_unpenalized ? `PENALIZED ${game.seconds_till_unpenalized} s` : "PENALIZED";
}

/** A ball seen relative to a robot, on the field by the robot's pose. */
export function onField(pose, rel) {
  const c = Math.cos(pose.theta), s = Math.sin(pose.theta);
  return { x: pose.x + c * rel.x - s * rel.y, y: pose.y + s * rel.x + c * rel.y };
}

/** Where the team thinks the ball is: its robots' fresh sightings (own pose + ball_relative) weighted by confidence;
 * null when none of them sees it. Fresh: arrived on this page within the last 2 s (of its clock, which a pause
 * holds still), so a replay's old stamps count as they are played. */
export function teamBall(store, robots) {
  let wx = 0, wy = 0, w = 0, seenBy = 0;
  const now = store.now();
  for (const robot of robots) {
    const ball = store.get(robot, "ball_relative")?.data;
    const pos = store.get(robot, "position")?.data;
    const arrived = store.arrivals.get(`${robot}|ball_relative`) ?? -Infinity;
    if (!ball || !pos || !(ball.confidence > 0) || now - arrived > SEEN_BALL_MAX_AGE_S * 1000) continue;
    const p = onField({ x: pos.pose.x, y: pos.pose.y, theta: pos.pose.theta }, ball.ball_relative);
    const weight = ball.confidence * Math.max(0.05, pos.confidence ?? 1);
    wx += weight * p.x; wy += weight * p.y; w += weight; seenBy++;
  }
  return w > 0 ? { x: wx / w, y: wy / w, seenBy } : null;
}
