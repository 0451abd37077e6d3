// Relative view: what the focused robot sees around itself (x forward is up): ball, goal, obstacles, lines.

import { expose } from "../test_hooks.js";
import { css, fitCanvas, obstacleColor } from "../msgtypes.js";

const TOPICS = [["ball_relative", 15], ["goal_relative", 5], ["obstacles_relative", 5], ["line_information_relative", 5]];
const RANGE_M = 5;

export default {
  id: "relative",
  title: "Relative view (focused robot)",
  size: [1, 2],
  create(body, ctx) {
    const { store } = ctx;
    const canvas = document.createElement("canvas");
    body.append(canvas);
    let dirty = true, raf = 0;
    const stats = { frames: 0, ball: null }; // what the last frame drew (tests and debugging)
    expose("relativeView", stats);
    const offs = TOPICS.map(([topic, hz]) => ctx.subscribe(topic, hz, (f) => { if (f.robot === store.focus) dirty = true; }));
    offs.push(store.on("focus", () => { dirty = true; }), store.on("theme", () => { dirty = true; }));

    function draw() {
      const { ctx: g, w, h } = fitCanvas(canvas);
      const scale = Math.min(w, h) / (2 * RANGE_M);
      const ox = w / 2, oy = h / 2;
      // robot frame: x forward (screen up), y left (screen left)
      const P = (p) => [ox - p.y * scale, oy - p.x * scale];
      g.fillStyle = css("--panel"); g.fillRect(0, 0, w, h);
      g.strokeStyle = css("--muted"); g.lineWidth = 1; g.fillStyle = css("--muted"); g.font = "12px sans-serif";
      for (let r = 1; r <= RANGE_M; r++) {
        g.beginPath(); g.arc(ox, oy, r * scale, 0, 2 * Math.PI); g.stroke();
        g.fillText(`${r} m`, ox + 3, oy - r * scale + 12);
      }
      g.fillStyle = css("--fg");
      g.beginPath(); g.moveTo(ox, oy - 14); g.lineTo(ox - 9, oy + 9); g.lineTo(ox + 9, oy + 9); g.closePath(); g.fill();
      const robot = store.focus;
      g.font = "bold 14px sans-serif";
      g.fillText(robot || "no robot focused", 8, 18);
      const lines = store.get(robot, "line_information_relative")?.data;
      if (lines) {
        g.strokeStyle = "#808080"; g.lineWidth = 3;
        for (const s of lines.segments) { seg(g, P, s); }
        for (const c of lines.circles) { seg(g, P, c.left); seg(g, P, c.right); }
        g.fillStyle = "#808080";
        for (const i of lines.intersections) for (const s of i.segments) seg(g, P, s);
      }
      const goal = store.get(robot, "goal_relative")?.data;
      if (goal && goal.confidence > 0) {
        g.strokeStyle = "#00a0c0"; g.lineWidth = 6;
        const [lx, ly] = P(goal.left_post), [rx, ry] = P(goal.right_post);
        g.beginPath(); g.moveTo(lx, ly); g.lineTo(rx, ry); g.stroke();
        g.lineWidth = 2; g.setLineDash([6, 4]);
        const [cx, cy] = P(goal.center_direction);
        g.beginPath(); g.moveTo(ox, oy); g.lineTo(cx, cy); g.stroke(); g.setLineDash([]);
        label(g, lx, ly, `goal ${goal.confidence.toFixed(2)}`);
      }
      for (const o of store.get(robot, "obstacles_relative")?.data?.obstacles || []) {
        const [x, y] = P(o.position);
        const size = Math.max(8, (o.width || 0.2) * scale);
        const color = obstacleColor(o.color);
        g.fillStyle = color === "ROBOT_MAGENTA" ? "#ff00ff" : color === "ROBOT_CYAN" ? "#00c8ff" : "#333";
        g.fillRect(x - size / 2, y - size / 2, size, size);
        label(g, x, y, o.confidence.toFixed(2));
      }
      const ball = store.get(robot, "ball_relative")?.data;
      stats.frames++;
      stats.ball = ball && ball.confidence > 0 ? { x: ball.ball_relative.x, y: ball.ball_relative.y } : null;
      if (ball && ball.confidence > 0) {
        const [x, y] = P(ball.ball_relative);
        g.fillStyle = "#ff8c00"; g.strokeStyle = "#000"; g.lineWidth = 2;
        g.beginPath(); g.arc(x, y, 8, 0, 2 * Math.PI); g.fill(); g.stroke();
        label(g, x, y, `ball ${ball.confidence.toFixed(2)}`);
      }
    }

    function loop() {
      raf = requestAnimationFrame(loop);
      if (dirty) { dirty = false; draw(); }
    }
    raf = requestAnimationFrame(loop);
    return { destroy() { cancelAnimationFrame(raf); offs.forEach((off) => off()); }, resize() { dirty = true; } };
  },
};

function seg(g, P, s) {
  const [ax, ay] = P(s.start), [bx, by] = P(s.end);
  g.beginPath(); g.moveTo(ax, ay); g.lineTo(bx, by); g.stroke();
}

function label(g, x, y, text) {
  g.font = "bold 12px sans-serif"; g.fillStyle = css("--fg");
  g.fillText(text, x + 10, y - 8);
}
