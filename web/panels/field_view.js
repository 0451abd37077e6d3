// Field view: the kid-size field to scale, robot poses with confidence, ball, obstacles, teammates, game state.

import { css, fitCanvas, fmtClock, gameName, SECONDARY_STATES, yaw } from "../msgtypes.js";

// RoboCup Humanoid League kid-size field (metres)
export const FIELD = { length: 9, width: 6, goalDepth: 0.6, goalWidth: 2.6, goalAreaLength: 1, goalAreaWidth: 3,
  penaltyAreaLength: 2, penaltyAreaWidth: 5, penaltyMark: 1.5, centerCircle: 1.5, border: 0.7 };
const TOPICS = [["position", 15], ["ground_truth", 15], ["ball_relative", 15], ["obstacles_relative", 5],
  ["team_data", 2], ["gamestate", 2]];

function transform(pose, p) {
  const c = Math.cos(pose.theta), s = Math.sin(pose.theta);
  return { x: pose.x + c * p.x - s * p.y, y: pose.y + s * p.x + c * p.y };
}

export default {
  id: "field",
  title: "Field view",
  size: [2, 3],
  create(body, ctx) {
    const { store } = ctx;
    const canvas = document.createElement("canvas");
    body.append(canvas);
    const stats = { drawn: [], frames: 0, fps: 0, balls: 0, drawMs: 0 }; // drawMs: time per draw (moving average)
    window.pitchside.fieldView = stats;
    let dirty = true, view = null, raf = 0, fpsStart = performance.now(), fpsFrames = 0;
    const offs = TOPICS.map(([topic, hz]) => ctx.subscribe(topic, hz, () => { dirty = true; }));
    offs.push(store.on("focus", () => { dirty = true; }), store.on("theme", () => { dirty = true; }));
    offs.push(store.on("robots", () => { dirty = true; }));

    /** Estimated poses (position) and ground truth, per robot id. */
    function poses() {
      const out = new Map();
      for (const robot of store.latest.keys()) {
        const gt = store.get(robot, "ground_truth")?.data;
        if (gt) {
          gt.robot_ids.forEach((id, i) => {
            const p = gt.robot_poses[i];
            const entry = out.get(id) || {};
            entry.truth = { x: p.position.x, y: p.position.y, theta: yaw(p.orientation) };
            out.set(id, entry);
          });
        }
      }
      for (const robot of store.latest.keys()) {
        const pos = store.get(robot, "position")?.data;
        const overview = store.get(robot, "overview")?.data;
        const entry = out.get(robot) || {};
        if (pos) entry.estimate = { x: pos.pose.x, y: pos.pose.y, theta: pos.pose.theta, confidence: pos.confidence };
        else if (overview?.pose_known) {
          entry.estimate = { x: overview.pose_x, y: overview.pose_y, theta: overview.pose_theta,
            confidence: overview.pose_confidence };
        }
        if (entry.estimate || entry.truth) out.set(robot, entry);
      }
      return out;
    }

    function draw() {
      const { ctx: g, w, h } = fitCanvas(canvas);
      const F = FIELD;
      const scale = Math.min(w / (F.length + 2 * F.border), (h - 28) / (F.width + 2 * F.border));
      const ox = w / 2, oy = 28 + (h - 28) / 2;
      const X = (x) => ox + x * scale, Y = (y) => oy - y * scale;
      view = { X, Y, scale };
      g.fillStyle = css("--field");
      g.fillRect(0, 0, w, h);
      g.strokeStyle = "#ffffff";
      g.lineWidth = Math.max(2, 0.05 * scale);
      const L = F.length / 2, W = F.width / 2;
      g.strokeRect(X(-L), Y(W), F.length * scale, F.width * scale);
      g.beginPath(); g.moveTo(X(0), Y(W)); g.lineTo(X(0), Y(-W)); g.stroke();
      g.beginPath(); g.arc(X(0), Y(0), F.centerCircle / 2 * scale, 0, 2 * Math.PI); g.stroke();
      for (const side of [-1, 1]) {
        const gx = side * L;
        g.strokeRect(Math.min(X(gx), X(gx - side * F.goalAreaLength)), Y(F.goalAreaWidth / 2),
          F.goalAreaLength * scale, F.goalAreaWidth * scale);
        g.strokeRect(Math.min(X(gx), X(gx - side * F.penaltyAreaLength)), Y(F.penaltyAreaWidth / 2),
          F.penaltyAreaLength * scale, F.penaltyAreaWidth * scale);
        g.fillStyle = "#ffffff";
        g.fillRect(X(gx - side * F.penaltyMark) - 3, Y(0) - 3, 6, 6);
        g.save();
        g.strokeStyle = side < 0 ? "#ffe600" : "#00e5ff"; // own goal yellow, opponent goal cyan
        g.lineWidth = Math.max(3, 0.08 * scale);
        g.strokeRect(Math.min(X(gx), X(gx + side * F.goalDepth)), Y(F.goalWidth / 2), F.goalDepth * scale,
          F.goalWidth * scale);
        g.restore();
      }
      const all = poses();
      const drawn = [];
      let balls = 0;
      // teammates reported over team communication (small, hollow)
      const team = store.get(store.focus, "team_data")?.data;
      if (team) {
        team.robot_ids.forEach((id, i) => {
          const p = team.robot_positions[i]?.pose;
          if (!p) return;
          g.strokeStyle = "#ffffff"; g.lineWidth = 2;
          g.beginPath(); g.arc(X(p.x), Y(p.y), 0.15 * scale, 0, 2 * Math.PI); g.stroke();
          g.fillStyle = "#ffffff"; g.font = "bold 12px sans-serif"; g.fillText(`#${id}`, X(p.x) + 8, Y(p.y) - 8);
        });
      }
      const silent = new Set(store.robots.filter((r) => store.robotAge(r) >= ctx.config.stale_after_s).map((r) => r.robot));
      for (const [id, entry] of all) {
        const focused = id === store.focus;
        g.globalAlpha = silent.has(id) ? 0.45 : 1; // old news: drawn faded, labelled below
        if (entry.truth) robotShape(g, X, Y, scale, entry.truth, "#ffffff", 0, focused);
        if (entry.estimate) {
          const c = Math.max(0, Math.min(1, entry.estimate.confidence ?? 1));
          robotShape(g, X, Y, scale, entry.estimate, focused ? "#ff2d95" : "#1f3cff", 0.35 + 0.65 * c, focused);
          g.strokeStyle = "#000"; g.lineWidth = 1; g.setLineDash([4, 3]);
          g.beginPath(); g.arc(X(entry.estimate.x), Y(entry.estimate.y), (0.25 + (1 - c) * 0.6) * scale, 0, 2 * Math.PI);
          g.stroke(); g.setLineDash([]);
        }
        const pose = entry.estimate || entry.truth;
        const name = silent.has(id) ? `${id} (silent)` : id;
        g.globalAlpha = 1;
        g.fillStyle = "#ffffff"; g.strokeStyle = "#000"; g.lineWidth = 3; g.font = "bold 14px sans-serif";
        g.strokeText(name, X(pose.x) + 12, Y(pose.y) + 18); g.fillText(name, X(pose.x) + 12, Y(pose.y) + 18);
        drawn.push({ id, x: pose.x, y: pose.y, silent: silent.has(id) });
        const ball = store.get(id, "ball_relative")?.data;
        if (ball && entry.estimate && ball.confidence > 0) {
          const b = transform(entry.estimate, ball.ball_relative);
          ballShape(g, X(b.x), Y(b.y), scale, 0.3 + 0.7 * Math.min(1, ball.confidence));
          balls++;
        }
        for (const o of store.get(id, "obstacles_relative")?.data?.obstacles || []) {
          if (!entry.estimate) break;
          const p = transform(entry.estimate, o.position);
          g.fillStyle = o.color === 2 ? "#ff00ff" : o.color === 3 ? "#00ffff" : "#222";
          g.fillRect(X(p.x) - 0.1 * scale, Y(p.y) - 0.1 * scale, 0.2 * scale, 0.2 * scale);
        }
      }
      for (const robot of store.latest.keys()) {
        const gt = store.get(robot, "ground_truth")?.data;
        if (gt) { ballShape(g, X(gt.ball.x), Y(gt.ball.y), scale, 1, true); balls++; }
      }
      drawGameState(g, w);
      stats.drawn = drawn;
      stats.balls = balls;
    }

    function drawGameState(g, w) {
      g.fillStyle = "#000000";
      g.fillRect(0, 0, w, 28);
      const ids = [store.focus, ...store.latest.keys()];
      const game = ids.map((id) => store.get(id, "gamestate")?.data).find(Boolean);
      g.fillStyle = "#ffffff";
      g.font = "bold 18px sans-serif";
      if (!game) { g.fillText("no game state", 8, 20); return; }
      const secondary = game.secondary_state ? ` ${SECONDARY_STATES[game.secondary_state] ?? ""}` : "";
      const penalized = [];
      for (const id of store.latest.keys()) if (store.get(id, "gamestate")?.data?.penalized) penalized.push(id);
      const text = `${gameName(game.game_state)}${secondary}   ${game.own_score} : ${game.rival_score}   ` +
        `${fmtClock(game.seconds_remaining)}${game.first_half ? " 1st" : " 2nd"}` +
        (penalized.length ? `   penalized: ${penalized.join(", ")}` : "");
      g.fillText(text, 8, 20);
    }

    function loop() {
      raf = requestAnimationFrame(loop);
      if (!dirty) return;
      dirty = false;
      const t0 = performance.now();
      draw();
      stats.drawMs = stats.frames ? 0.9 * stats.drawMs + 0.1 * (performance.now() - t0) : performance.now() - t0;
      stats.frames++;
      fpsFrames++;
      const now = performance.now();
      if (now - fpsStart >= 1000) { stats.fps = fpsFrames * 1000 / (now - fpsStart); fpsFrames = 0; fpsStart = now; }
    }
    raf = requestAnimationFrame(loop);

    canvas.addEventListener("click", (e) => {
      if (!view) return;
      const rect = canvas.getBoundingClientRect();
      const px = e.clientX - rect.left, py = e.clientY - rect.top;
      let best = null, bestD = 0.5 * view.scale;
      for (const r of stats.drawn) {
        const d = Math.hypot(view.X(r.x) - px, view.Y(r.y) - py);
        if (d < bestD) { best = r.id; bestD = d; }
      }
      if (best) store.setFocus(best);
    });
    return {
      destroy() { cancelAnimationFrame(raf); offs.forEach((off) => off()); },
      resize() { dirty = true; },
    };
  },
};

function robotShape(g, X, Y, scale, pose, color, alpha, focused) {
  const r = 0.2 * scale;
  g.save();
  g.translate(X(pose.x), Y(pose.y));
  g.rotate(-pose.theta);
  g.beginPath();
  g.moveTo(r * 1.4, 0); g.lineTo(-r, r); g.lineTo(-r, -r); g.closePath();
  if (alpha > 0) { g.globalAlpha = alpha; g.fillStyle = color; g.fill(); g.globalAlpha = 1; }
  g.strokeStyle = alpha > 0 ? "#000000" : color;
  g.lineWidth = focused ? 4 : 2;
  g.stroke();
  g.restore();
}

function ballShape(g, x, y, scale, alpha, truth = false) {
  g.globalAlpha = alpha;
  g.fillStyle = truth ? "#ffffff" : "#ff8c00";
  g.strokeStyle = "#000000";
  g.lineWidth = 2;
  g.beginPath(); g.arc(x, y, Math.max(5, 0.08 * scale), 0, 2 * Math.PI); g.fill(); g.stroke();
  g.globalAlpha = 1;
}
