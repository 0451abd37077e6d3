// Camera: the focused robot's JPEG with the vision's markers (balls, goal parts, obstacles, lines), each toggleable.

import { expose } from "../test_hooks.js";
import { KEYS, getJSON, setJSON } from "../settings.js";
import { fitCanvas } from "../msgtypes.js";

const IMAGE = "camera/image/compressed";
const CLASSES = [
  ["ball_in_image", "balls", "#ff8c00"],
  ["goal_in_image", "goal", "#00e5ff"],
  ["obstacles_in_image", "obstacles", "#ff00ff"],
  ["line_information_in_image", "lines", "#ffffff"],
];

export default {
  id: "camera",
  title: "Camera (focused robot)",
  size: [1, 2],
  create(body, ctx) {
    const { store } = ctx;
    const shown = getJSON(KEYS.camera, {}) ?? {};
    body.innerHTML = `<div class="camera-controls">${CLASSES.map(([topic, label, color]) =>
      `<label style="border-bottom: 4px solid ${color}"><input type="checkbox" data-topic="${topic}"
        ${shown[topic] === false ? "" : "checked"}> ${label}</label>`).join("")}</div>
      <div class="camera-view"><canvas></canvas></div>`;
    const canvas = body.querySelector("canvas");
    const stats = { images: 0, width: 0, height: 0, markers: {} };
    expose("camera", stats);
    let bitmap = null, dirty = true, raf = 0, decoding = false, pending = null;
    body.querySelectorAll("input").forEach((box) => box.addEventListener("change", () => {
      shown[box.dataset.topic] = box.checked;
      setJSON(KEYS.camera, shown);
      dirty = true;
    }));

    async function decode(frame) {
      if (decoding) { pending = frame; return; } // keep only the newest while one decodes
      decoding = true;
      try {
        const next = await createImageBitmap(frame.blob);
        bitmap?.close?.();
        bitmap = next;
        stats.images++;
        stats.width = next.width;
        stats.height = next.height;
        dirty = true;
      } catch (err) {
        console.warn("camera image did not decode", err);
      } finally {
        decoding = false;
        if (pending) { const f = pending; pending = null; decode(f); }
      }
    }

    const offs = [ctx.subscribe(IMAGE, 10, (f) => { if (f.robot === store.focus) decode(f); })];
    for (const [topic] of CLASSES) offs.push(ctx.subscribe(topic, 10, (f) => { if (f.robot === store.focus) dirty = true; }));
    offs.push(store.on("focus", () => {
      bitmap = null; dirty = true;
      const f = store.get(store.focus, IMAGE);
      if (f) decode(f);
    }));

    function draw() {
      const { ctx: g, w, h } = fitCanvas(canvas);
      g.fillStyle = "#000"; g.fillRect(0, 0, w, h);
      if (!bitmap) {
        g.fillStyle = "#fff"; g.font = "16px sans-serif"; g.fillText(`no image from ${store.focus || "any robot"}`, 10, 24);
        return;
      }
      const s = Math.min(w / bitmap.width, h / bitmap.height);
      const ox = (w - bitmap.width * s) / 2, oy = (h - bitmap.height * s) / 2;
      g.drawImage(bitmap, ox, oy, bitmap.width * s, bitmap.height * s);
      /** @returns {[number, number]} */
      const P = (p) => [ox + p.x * s, oy + p.y * s];
      const robot = store.focus;
      for (const [topic, , color] of CLASSES) {
        const data = shown[topic] === false ? null : store.get(robot, topic)?.data;
        stats.markers[topic] = 0;
        if (!data) continue;
        g.strokeStyle = color; g.fillStyle = color; g.lineWidth = 3; g.font = "bold 13px sans-serif";
        if (topic === "ball_in_image") {
          for (const b of data.candidates) {
            const [x, y] = P(b.center);
            g.beginPath(); g.arc(x, y, Math.max(4, b.diameter / 2 * s), 0, 2 * Math.PI); g.stroke();
            text(g, b.confidence, x + b.diameter / 2 * s + 3, y);
            stats.markers[topic]++;
          }
        } else if (topic === "goal_in_image") {
          for (const p of data.posts) { line(g, P(p.foot_point), P(p.top_point), Math.max(3, p.width * s));
            text(g, p.confidence, ...P(p.top_point)); stats.markers[topic]++; }
          for (const b of data.bars) { line(g, P(b.left_point), P(b.right_point), Math.max(3, b.width * s));
            stats.markers[topic]++; }
        } else if (topic === "obstacles_in_image") {
          for (const o of data.obstacles) {
            const [x, y] = P(o.top_left);
            g.strokeRect(x, y, o.width * s, o.height * s);
            text(g, o.confidence, x, y - 4);
            stats.markers[topic]++;
          }
        } else {
          g.lineWidth = 2;
          for (const seg of data.segments) { line(g, P(seg.start), P(seg.end), 2); stats.markers[topic]++; }
          for (const c of data.circles) { line(g, P(c.left.start), P(c.left.end), 2); line(g, P(c.right.start), P(c.right.end), 2); }
          for (const i of data.intersections) for (const seg of i.segments) line(g, P(seg.start), P(seg.end), 2);
        }
      }
    }

    function loop() {
      raf = requestAnimationFrame(loop);
      if (dirty) { dirty = false; draw(); }
    }
    raf = requestAnimationFrame(loop);
    const f = store.get(store.focus, IMAGE);
    if (f) decode(f);
    return { destroy() { cancelAnimationFrame(raf); offs.forEach((off) => off()); }, resize() { dirty = true; } };
  },
};

function line(g, [ax, ay], [bx, by], width) {
  g.lineWidth = width;
  g.beginPath(); g.moveTo(ax, ay); g.lineTo(bx, by); g.stroke();
}

function text(g, confidence, x, y) {
  const label = confidence.toFixed(2);
  g.save(); g.lineWidth = 3; g.strokeStyle = "#000"; g.strokeText(label, x, y); g.fillText(label, x, y); g.restore();
}
