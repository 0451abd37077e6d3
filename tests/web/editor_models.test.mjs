// node --test tests/web/: the animation editor's pure parts (web/panels/animation_editor.js): joint groups by name,
// goals to the step the editor keeps, default keyframe names.
import { test } from "node:test";
import assert from "node:assert/strict";
import { fmtDeg, jointGroup, newKeyframeName, servoDeg } from "../../web/panels/animation_editor.js";

test("joint groups from the joints' names (the Minibot's, the Wolfgang's, snake_case)", () => {
  const names = ["HeadPan", "HeadTilt", "LShoulderPitch", "LElbow", "RShoulderRoll", "RHipYaw", "LKnee", "RAnkleRoll",
    "left_knee", "r_hip_pitch", "Torso"];
  assert.deepEqual(names.map(jointGroup), ["head", "head", "L-arm", "L-arm", "R-arm", "R-leg", "L-leg", "R-leg",
    "L-leg", "R-leg", ""]);
});

test("goals to a tenth of a degree, shown without trailing zeros", () => {
  assert.equal(servoDeg(90.000210459), 90);
  assert.equal(servoDeg(-29.97), -30);
  assert.equal(servoDeg(44.69), 44.7);
  assert.equal(fmtDeg(-90), "-90");
  assert.equal(fmtDeg(12.34), "12.3");
});

test("a new keyframe's name is one no keyframe has", () => {
  assert.equal(newKeyframeName({ keyframes: [] }), "kf 0");
  assert.equal(newKeyframeName({ keyframes: [{ name: "start" }, { name: "kf 1" }] }), "kf 2");
  assert.equal(newKeyframeName({ keyframes: [{ name: "kf 2" }, { name: "x" }] }), "kf 3");
});
