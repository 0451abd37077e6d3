// The field view's drawing of the field itself and of robot and ball shapes, on a 2D canvas: the field to scale
// (RoboCup Humanoid League kid-size), cached offscreen; web/panels/field_view.js draws the game on top.

import { css } from "../msgtypes.js";

// RoboCup Humanoid League kid-size field (metres)
export const FIELD = { length: 9, width: 6, goalDepth: 0.6, goalWidth: 2.6, goalAreaLength: 1, goalAreaWidth: 3,
  penaltyAreaLength: 2, penaltyAreaWidth: 5, penaltyMark: 1.5, centerCircle: 1.5, border: 0.7 };
export const HEADER = 28; // px: the game state bar

/** Metres to pixels: the field with its border fits below the game state bar, centred. */
export function fieldScale(w, h) {
  const F = FIELD;
  const scale = Math.min(w / (F.length + 2 * F.border), (h - HEADER) / (F.width + 2 * F.border));
  const ox = w / 2, oy = HEADER + (h - HEADER) / 2;
  return { X: (x) => ox + x * scale, Y: (y) => oy - y * scale, scale };
}

/** Grass, lines and goals into an offscreen canvas of the visible one's size: one drawImage per frame. */
export function staticField(fv, w, h, scale, X, Y) {
  const { canvas } = fv;
  const key = `${canvas.width}x${canvas.height}|${fv.theme}`;
  if (fv.field?.key === key) return fv.field.canvas;
  const off = fv.field?.canvas || document.createElement("canvas");
  off.width = canvas.width;
  off.height = canvas.height;
  const g = off.getContext("2d");
  g.setTransform(canvas.width / w, 0, 0, canvas.height / h, 0, 0);
  const F = FIELD;
  g.fillStyle = css("--field");
  g.fillRect(0, 0, w, h);
  g.strokeStyle = css("--field-line") || "#ffffff";
  g.lineWidth = Math.max(2, 0.05 * scale);
  const L = F.length / 2, W = F.width / 2;
  g.strokeRect(X(-L), Y(W), F.length * scale, F.width * scale);
  g.beginPath(); g.moveTo(X(0), Y(W)); g.lineTo(X(0), Y(-W)); g.stroke();
  g.beginPath(); g.arc(X(0), Y(0), F.centerCircle / 2 * scale, 0, 2 * Math.PI); g.stroke();
  for (const side of [-1, 1]) fieldEnd(g, side * L, side, scale, X, Y);
  fv.field = { key, canvas: off };
  return off;
}

/** One end of the field: goal area, penalty area, penalty mark and the goal (own yellow, opponent cyan). */
function fieldEnd(g, gx, side, scale, X, Y) {
  const F = FIELD;
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

/** A robot as a triangle pointing where it faces: filled (alpha > 0) for an estimate, hollow for ground truth. */
export function robotShape(g, X, Y, scale, pose, color, alpha, focused) {
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

/** A ball: orange as a robot sees it (outlined in its team's colour), white where the simulator has it. */
export function ballShape(g, x, y, scale, alpha, truth = false, outline = "#000000") {
  g.globalAlpha = alpha;
  g.fillStyle = truth ? "#ffffff" : "#ff8c00";
  g.strokeStyle = outline;
  g.lineWidth = 2;
  g.beginPath(); g.arc(x, y, Math.max(5, 0.08 * scale), 0, 2 * Math.PI); g.fill(); g.stroke();
  g.globalAlpha = 1;
}
