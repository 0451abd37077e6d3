// node --test tests/web/: how the field view moves a robot between samples (web/models/field_motion.js):
// extrapolated a short way past the newest sample, never further; a jump shown at once.
import { test } from "node:test";
import assert from "node:assert/strict";
import { MOTION, Track } from "../../web/models/field_motion.js";

test("between 15 Hz samples a walking robot glides on, at most the horizon past its newest sample", () => {
  const t = new Track();
  t.update("a", { x: 0, y: 0, theta: 0 }, 10.0, 1000);
  t.update("b", { x: 0.02, y: 0, theta: 0 }, 10.1, 1100); // 0.2 m/s
  const soon = t.pose(1150);
  assert.ok(Math.abs(soon.x - (0.02 + 0.2 * 0.05)) < 1e-6, soon.x);
  const late = t.pose(5000); // the stream stopped: no further than the horizon
  assert.ok(Math.abs(late.x - (0.02 + 0.2 * MOTION.horizonS)) < 1e-6, late.x);
});

test("the same frame twice changes nothing; an impossible speed is no velocity", () => {
  const t = new Track();
  t.update("a", { x: 0, y: 0, theta: 0 }, 1.0, 0);
  t.update("a", { x: 5, y: 0, theta: 0 }, 1.1, 100);
  assert.deepEqual(t.p, { x: 0, y: 0, theta: 0 });
  t.update("b", { x: 5, y: 0, theta: 0 }, 1.1, 100); // 50 m/s: a teleport or a seek
  assert.deepEqual(t.v, { x: 0, y: 0, theta: 0 });
  assert.equal(t.pose(100).x, 5, "a jump is shown at once, not faded in");
});

test("turning through pi is a small turn, not a jump", () => {
  const t = new Track();
  t.update("a", { x: 0, y: 0, theta: Math.PI - 0.05 }, 1.0, 0);
  t.update("b", { x: 0, y: 0, theta: -Math.PI + 0.05 }, 1.1, 100);
  assert.ok(Math.abs(t.v.theta - 1.0) < 1e-9, t.v.theta);
});
