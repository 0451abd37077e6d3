// Field view: the kid-size field to scale, robot poses with confidence in their team's colour with their roles, the
// ball each robot sees and the ball each team sees, obstacles, teammates, and the game: state, score, half, time.
// Drawn on every animation frame while the panel is on screen (none while hidden, scrolled away or in a background
// tab); poses glide between the 15 Hz updates: extrapolated a short way past the newest sample, never further.
// One view object holds the panel's state; each function below draws one part or handles one event.

import { expose } from "../test_hooks.js";
import { FIELD, HEADER, ballShape, fieldScale, robotShape, staticField } from "./field_drawing.js";
import { MOTION, Track } from "../models/field_motion.js";
import { css, fitCanvas, fmtClock, gameName, obstacleColor, secondaryName, yaw } from "../msgtypes.js";
import { onField, roleOf, teamBall, teamColour, teamOf, teamsOf } from "../teams.js";

export { FIELD, MOTION, Track }; // where the tests and other views find them

const TOPICS = [["position", 15], ["ground_truth", 15], ["ball_relative", 15], ["obstacles_relative", 5],
  ["team_data", 2], ["gamestate", 2], ["strategy", 2], ["overview", 5]]; // overview: a robot heard by telemetry only
const REPLAY_COLOUR = "#9b2fd1"; // replayed robots (the page's --replay)
const FOCUS_COLOUR = "#ff2d95"; // the ring around the focused robot
const NO_TEAM_COLOUR = "#1f3cff"; // a robot whose team is not known yet

const transform = onField; // a point relative to a robot (its x forward) on the field, given the robot's pose

export default {
  id: "field",
  title: "Field view",
  size: [2, 3],
  create(body, ctx) {
    const fv = newFieldView(body, ctx);
    expose("fieldView", fv.stats);
    fv.offs = TOPICS.map(([topic, hz]) => ctx.subscribe(topic, hz, () => {}));
    fv.offs.push(ctx.store.on("theme", () => { fv.theme++; }));
    fv.seen = new IntersectionObserver((entries) => {
      fv.onScreen = entries[entries.length - 1].isIntersecting;
      fv.schedule();
    });
    fv.seen.observe(fv.canvas);
    document.addEventListener("visibilitychange", fv.schedule);
    fv.raf = requestAnimationFrame(fv.loop); // the observer's first report follows; until then, assume on screen
    fv.stats.running = true;
    fv.canvas.addEventListener("click", (e) => focusAt(fv, e));
    return { destroy() { closeFieldView(fv); }, resize() { fv.schedule(); } };
  },
};

/** The view: its canvas, the figures tests and benchmarks read (stats), the animation loop and the tracks. */
function newFieldView(body, ctx) {
  const canvas = document.createElement("canvas");
  // show/hide per robot: one checkbox per robot on the field, its colour beside its name (live, or REPLAY)
  const legend = document.createElement("div");
  legend.className = "field-legend";
  legend.setAttribute("aria-label", "robots shown on the field");
  legend.addEventListener("change", (e) => {
    const box = /** @type {HTMLInputElement} */ (e.target);
    const robot = /** @type {HTMLElement | null} */ (box.closest("[data-robot]"))?.dataset.robot;
    if (robot !== undefined) ctx.store.setShown(robot, box.checked);
  });
  body.style.position = "relative";
  body.append(canvas, legend);
  const fv = {
    ctx, store: ctx.store, canvas, legend, legendKey: "",
    // frames: drawn so far (tests and bench/server.py read it); fps: over the last second; drawMs: per draw (average)
    stats: { drawn: [], frames: 0, fps: 0, balls: 0, drawMs: 0, running: false },
    view: null, raf: 0, fpsStart: performance.now(), fpsFrames: 0, onScreen: true, destroyed: false,
    theme: 0, field: null, // the static field (grass, lines, goals) drawn once per size and theme
    tracks: new Map(), // "kind|robot" -> Track
    offs: [], seen: null,
  };
  // bound once, so they can be handed to requestAnimationFrame and removed as listeners again
  fv.loop = () => loop(fv);
  fv.schedule = () => schedule(fv);
  return fv;
}

/** The panel closed: the loop stops, the observers and subscriptions end. */
function closeFieldView(fv) {
  fv.destroyed = true;
  fv.schedule();
  fv.seen.disconnect();
  document.removeEventListener("visibilitychange", fv.schedule);
  fv.offs.forEach((off) => off());
}

// -- where things are -------------------------------------------------------------------------------

/** The shown pose of one moving thing, following its newest sample smoothly; marked in use for this frame. */
function track(fv, key, frame, p, now) {
  let t = fv.tracks.get(key);
  if (!t) fv.tracks.set(key, t = new Track());
  t.update(frame, p, frame.stamp, now);
  t.used = true;
  return t.pose(now);
}

/** Shown poses of estimates (position) and ground truth, per robot id. */
function poses(fv, now) {
  const { store } = fv;
  const out = new Map();
  for (const [id, { frame, index }] of truthFrames(store)) {
    const p = frame.data.robot_poses[index];
    out.set(id, { truth: track(fv, `truth|${id}`, frame,
      { x: p.position.x, y: p.position.y, theta: yaw(p.orientation) }, now) });
  }
  for (const robot of store.latest.keys()) {
    const frame = store.get(robot, "position");
    const overview = store.get(robot, "overview")?.data;
    const entry = out.get(robot) || {};
    if (frame) {
      const pos = frame.data;
      entry.estimate = track(fv, `estimate|${robot}`, frame,
        { x: pos.pose.x, y: pos.pose.y, theta: pos.pose.theta, confidence: pos.confidence }, now);
    } else if (overview?.pose_known) {
      entry.estimate = { x: overview.pose_x, y: overview.pose_y, theta: overview.pose_theta,
        confidence: overview.pose_confidence };
    }
    if (entry.estimate || entry.truth) out.set(robot, entry);
  }
  return out;
}

/** Per robot id, the newest ground truth frame that has it (several simulators may report the same robot) and the
 * robot's index in it. A replayed frame names the log's robots: they are the replayed ones, never the live ones. */
function truthFrames(store) {
  const truths = new Map();
  for (const robot of store.latest.keys()) {
    const frame = store.get(robot, "ground_truth");
    if (!frame) continue;
    const replayed = store.isReplayed(robot);
    frame.data.robot_ids.forEach((named, index) => {
      const id = replayed ? store.replayedId(named) : named;
      if (id !== undefined && !(truths.get(id)?.frame.stamp >= frame.stamp)) truths.set(id, { frame, index });
    });
  }
  return truths;
}

// -- drawing ----------------------------------------------------------------------------------------

/** One frame: the field, teammates, every robot with its ball and obstacles, true balls, the game state bar. */
function draw(fv, now) {
  const { store, stats } = fv;
  const { ctx: g, w, h } = fitCanvas(fv.canvas);
  const view = fv.view = fieldScale(w, h);
  const background = staticField(fv, w, h, view.scale, view.X, view.Y);
  g.save();
  g.setTransform(1, 0, 0, 1, 0, 0);
  g.drawImage(background, 0, 0);
  g.restore();
  for (const t of fv.tracks.values()) t.used = false;
  const all = poses(fv, now);
  drawTeammates(fv, g, view);
  const silent = new Set(store.robots.filter((r) => store.robotAge(r) >= fv.ctx.config.stale_after_s)
    .map((r) => r.robot));
  const drawn = [];
  let balls = 0;
  // replayed robots first, live ones over them, the focused one on top: a replay never covers a live robot
  const order = [...all].filter(([id]) => !store.hidden.has(id)).sort(([a], [b]) =>
    (Number(store.isReplayed(b)) - Number(store.isReplayed(a))) || (Number(a === store.focus) - Number(b === store.focus)));
  for (const [id, entry] of order) {
    drawn.push(drawRobot(fv, g, view, id, entry, silent.has(id)));
    if (drawSeenBall(fv, g, view, id, entry, now)) balls++;
    drawObstacles(fv, g, view, id, entry);
  }
  stats.labels = placeLabels(g, view, drawn, store);
  showLegend(fv, [...all.keys()]);
  balls += drawTrueBalls(fv, g, view, now);
  stats.teamBalls = drawTeamBalls(fv, g, view);
  for (const [key, t] of fv.tracks) if (!t.used) fv.tracks.delete(key); // gone from the store
  drawGameState(fv, g, w);
  stats.drawn = drawn;
  stats.balls = balls;
}

/** Where each team sees the ball (its robots' sightings, weighted): a ring in the team's colour. */
function drawTeamBalls(fv, g, { X, Y, scale }) {
  const out = [];
  for (const team of teamsOf(fv.store, [...fv.store.latest.keys()])) {
    if (team.colour === undefined) continue;
    const ball = teamBall(fv.store, team.robots);
    if (!ball) continue;
    g.save();
    g.strokeStyle = "#000000"; g.lineWidth = 5;
    g.beginPath(); g.arc(X(ball.x), Y(ball.y), Math.max(9, 0.16 * scale), 0, 2 * Math.PI); g.stroke();
    g.strokeStyle = team.css; g.lineWidth = 3;
    g.beginPath(); g.arc(X(ball.x), Y(ball.y), Math.max(9, 0.16 * scale), 0, 2 * Math.PI); g.stroke();
    g.restore();
    out.push({ team: team.name, x: ball.x, y: ball.y, seenBy: ball.seenBy });
  }
  return out;
}

/** Teammates reported over team communication to the focused robot (small, hollow). */
function drawTeammates(fv, g, { X, Y, scale }) {
  const team = fv.store.get(fv.store.focus, "team_data")?.data;
  if (!team) return;
  team.robot_ids.forEach((id, i) => {
    const p = team.robot_positions[i]?.pose;
    if (!p) return;
    g.strokeStyle = "#ffffff"; g.lineWidth = 2;
    g.beginPath(); g.arc(X(p.x), Y(p.y), 0.15 * scale, 0, 2 * Math.PI); g.stroke();
    g.fillStyle = "#ffffff"; g.font = "bold 12px sans-serif"; g.fillText(`#${id}`, X(p.x) + 8, Y(p.y) - 8);
  });
}

/** A robot: ground truth hollow, the estimate filled by confidence in its team's colour with a ring as wide as its
 * doubt, the focused one ringed; its name and role. */
function drawRobot(fv, g, { X, Y, scale }, id, entry, silent) {
  const { store } = fv;
  const focused = id === store.focus;
  const colour = teamOf(store, id);
  const team = colour === undefined ? null : teamColour(colour);
  const role = roleOf(store, id);
  g.globalAlpha = silent ? 0.45 : 1; // old news: drawn faded, labelled below
  if (entry.truth) robotShape(g, X, Y, scale, entry.truth, "#ffffff", 0, focused);
  const pose = entry.estimate || entry.truth;
  if (focused) {
    g.strokeStyle = FOCUS_COLOUR; g.lineWidth = 5;
    g.beginPath(); g.arc(X(pose.x), Y(pose.y), 0.32 * scale, 0, 2 * Math.PI); g.stroke();
  }
  if (entry.estimate) {
    const c = Math.max(0, Math.min(1, entry.estimate.confidence ?? 1));
    const fill = store.isReplayed(id) ? REPLAY_COLOUR : team?.css ?? NO_TEAM_COLOUR; // the log's robots apart
    robotShape(g, X, Y, scale, entry.estimate, fill, 0.35 + 0.65 * c, focused);
    g.strokeStyle = "#000"; g.lineWidth = 1; g.setLineDash([4, 3]);
    g.beginPath(); g.arc(X(entry.estimate.x), Y(entry.estimate.y), (0.25 + (1 - c) * 0.6) * scale, 0, 2 * Math.PI);
    g.stroke(); g.setLineDash([]);
  }
  const name = `${id}${role ? ` ${role}` : ""}${silent ? " (silent)" : ""}`;
  g.globalAlpha = 1;
  return { id, x: pose.x, y: pose.y, silent, replayed: store.isReplayed(id), team: team?.name ?? "", role, name };
}

// where a label may go, relative to its robot (px): right below first, then above, left, further out
const LABEL_SPOTS = [[12, 18], [12, -12], [-12, 18], [-12, -12], [12, 36], [-12, 36], [12, -30], [-12, -30]];

/** Robots' names, live robots' first: each takes the first spot beside its robot that no label placed before
 * covers, so a replayed robot's name never covers a live one's. Returns the boxes (tests read them). */
function placeLabels(g, { X, Y }, drawn, store) {
  g.font = "bold 14px sans-serif";
  const boxes = [];
  const byPriority = [...drawn].sort((a, b) => (Number(a.replayed) - Number(b.replayed))
    || (Number(b.id === store.focus) - Number(a.id === store.focus)));
  for (const r of byPriority) {
    const w = g.measureText(r.name).width, h = 16;
    const at = (dx, dy) => ({ x: dx < 0 ? X(r.x) + dx - w : X(r.x) + dx, y: Y(r.y) + dy - 13, w, h });
    const free = (b) => boxes.every((o) => b.x + b.w <= o.x || o.x + o.w <= b.x || b.y + b.h <= o.y || o.y + o.h <= b.y);
    const box = LABEL_SPOTS.map(([dx, dy]) => at(dx, dy)).find(free) ?? at(...LABEL_SPOTS[0]);
    boxes.push({ id: r.id, replayed: r.replayed, ...box });
    g.fillStyle = r.replayed ? "#f0dcff" : "#ffffff"; g.strokeStyle = r.replayed ? REPLAY_COLOUR : "#000";
    g.lineWidth = 3;
    g.strokeText(r.name, box.x, box.y + 13); g.fillText(r.name, box.x, box.y + 13);
  }
  return boxes;
}

/** The legend: a checkbox per robot on the field, redrawn only when the robots or the choices change. */
function showLegend(fv, ids) {
  const { store } = fv;
  const sorted = ids.sort((a, b) => (store.isReplayed(a) - store.isReplayed(b)) || a.localeCompare(b));
  const colour = (id) => store.isReplayed(id) ? REPLAY_COLOUR
    : (teamOf(store, id) === undefined ? NO_TEAM_COLOUR : teamColour(teamOf(store, id)).css);
  const key = sorted.map((id) => `${id}:${store.hidden.has(id)}:${colour(id)}`).join("|");
  if (key === fv.legendKey) return;
  fv.legendKey = key;
  fv.legend.replaceChildren(...sorted.map((id) => {
    const label = document.createElement("label");
    label.dataset.robot = id;
    label.className = store.isReplayed(id) ? "replayed" : "live";
    label.title = store.isReplayed(id) ? `${id}: replayed from the open log` : `${id}: live`;
    const box = document.createElement("input");
    box.type = "checkbox";
    box.checked = !store.hidden.has(id);
    const swatch = document.createElement("span");
    swatch.className = "swatch";
    swatch.style.background = colour(id);
    label.append(box, swatch, document.createTextNode(id));
    return label;
  }));
}

/** The ball a robot sees, placed by its estimated pose, faded by confidence; true if one was drawn. */
function drawSeenBall(fv, g, { X, Y, scale }, id, entry, now) {
  const ballFrame = fv.store.get(id, "ball_relative");
  const ball = ballFrame?.data;
  if (!(ball && entry.estimate && ball.confidence > 0)) return false;
  const rel = track(fv, `ball|${id}`, ballFrame, { x: ball.ball_relative.x, y: ball.ball_relative.y, theta: 0 }, now);
  const b = transform(entry.estimate, rel);
  const colour = teamOf(fv.store, id);
  ballShape(g, X(b.x), Y(b.y), scale, 0.3 + 0.7 * Math.min(1, ball.confidence), false,
    colour === undefined ? "#000000" : teamColour(colour).css);
  return true;
}

/** The obstacles a robot sees, placed by its estimated pose, coloured by team. */
function drawObstacles(fv, g, { X, Y, scale }, id, entry) {
  for (const o of fv.store.get(id, "obstacles_relative")?.data?.obstacles || []) {
    if (!entry.estimate) break;
    const p = transform(entry.estimate, o.position);
    const color = obstacleColor(o.color);
    g.fillStyle = color === "ROBOT_MAGENTA" ? "#ff00ff" : color === "ROBOT_CYAN" ? "#00ffff" : "#222";
    g.fillRect(X(p.x) - 0.1 * scale, Y(p.y) - 0.1 * scale, 0.2 * scale, 0.2 * scale);
  }
}

/** The simulator's true ball (white), once per ground truth stream; returns how many were drawn. */
function drawTrueBalls(fv, g, { X, Y, scale }, now) {
  let balls = 0;
  for (const robot of fv.store.latest.keys()) {
    const frame = fv.store.get(robot, "ground_truth");
    if (!frame) continue;
    const b = track(fv, `truthball|${robot}`, frame, { x: frame.data.ball.x, y: frame.data.ball.y, theta: 0 }, now);
    ballShape(g, X(b.x), Y(b.y), scale, 1, true);
    balls++;
  }
  return balls;
}

/** The bar above the field: game state, score (by team colour when both teams are heard), clock, half, kick-off,
 * and who is penalized. */
function drawGameState(fv, g, w) {
  const { store } = fv;
  g.fillStyle = "#000000";
  g.fillRect(0, 0, w, HEADER);
  const from = store.gameSource(); // during a replay: the log's game
  const game = from === undefined ? undefined : store.get(from, "gamestate").data;
  g.fillStyle = "#ffffff";
  g.font = "bold 18px sans-serif";
  if (!game) { g.fillText("no game state", 8, 20); return; }
  const replayed = store.isReplayed(from);
  const robots = [...store.latest.keys()].filter((id) => store.isReplayed(id) === replayed);
  const secondary = game.secondary_state ? ` ${secondaryName(game.secondary_state)}` : "";
  const penalized = robots.filter((id) => store.get(id, "gamestate")?.data?.penalized);
  const teams = teamsOf(store, robots).filter((t) => t.colour !== undefined);
  const score = teams.length === 2
    ? `${teams[0].name.toUpperCase()} ${teams[0].score} : ${teams[1].score} ${teams[1].name.toUpperCase()}`
    : `${game.own_score} : ${game.rival_score}`;
  const kicking = teams.length === 2 ? teams.find((t) => t.kickOff) : null;
  const replay = replayed ? "REPLAY   " : ""; // the game of the open log, not the live one
  const text = `${replay}${gameName(game.game_state)}${secondary}   ${score}   ` +
    `${fmtClock(game.seconds_remaining)}${game.first_half ? " 1st" : " 2nd"}` +
    (kicking ? `   kick-off ${kicking.name}` : "") +
    (penalized.length ? `   penalized: ${penalized.join(", ")}` : "");
  g.fillText(text, 8, 20);
  fv.stats.gameBar = text;
}

// -- the animation loop ---------------------------------------------------------------------------

/** Whether the panel can be seen: not closed, on screen, in the page, in a visible tab. */
function wanted(fv) {
  return !fv.destroyed && fv.onScreen && fv.canvas.isConnected && document.visibilityState !== "hidden";
}

/** Starts or stops the animation loop: it runs only while the panel can be seen. */
function schedule(fv) {
  if (wanted(fv) && !fv.raf) fv.raf = requestAnimationFrame(fv.loop);
  else if (!wanted(fv) && fv.raf) { cancelAnimationFrame(fv.raf); fv.raf = 0; }
  fv.stats.running = !!fv.raf;
}

/** One animation frame: draw, and keep the draw time and frame rate figures. */
function loop(fv) {
  const { stats } = fv;
  fv.raf = 0;
  if (!wanted(fv)) { stats.running = false; return; }
  fv.raf = requestAnimationFrame(fv.loop);
  const t0 = performance.now();
  draw(fv, t0);
  const t1 = performance.now();
  stats.drawMs = stats.frames ? 0.9 * stats.drawMs + 0.1 * (t1 - t0) : t1 - t0;
  stats.frames++;
  fv.fpsFrames++;
  if (t1 - fv.fpsStart >= 1000) {
    stats.fps = fv.fpsFrames * 1000 / (t1 - fv.fpsStart);
    fv.fpsFrames = 0; fv.fpsStart = t1;
  }
}

/** A click near a drawn robot focuses it (within half a metre). */
function focusAt(fv, e) {
  const { view } = fv;
  if (!view) return;
  const rect = fv.canvas.getBoundingClientRect();
  const px = e.clientX - rect.left, py = e.clientY - rect.top;
  let best = null, bestD = 0.5 * view.scale;
  for (const r of fv.stats.drawn) {
    const d = Math.hypot(view.X(r.x) - px, view.Y(r.y) - py);
    if (d < bestD) { best = r.id; bestD = d; }
  }
  if (best) fv.store.setFocus(best);
}
