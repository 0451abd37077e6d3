// node --test tests/web/: the parameters panel's search (web/param_search.js), on the walking node's real
// parameter names and descriptions (robot_nodes/walking/gait.py) and the HCM's.
import { test } from "node:test";
import assert from "node:assert/strict";
import { matches } from "../../web/param_search.js";

const WALKING = [
  { name: "rate_hz", type: "float", doc: "engine cycles (walk_motor_goals) per second" },
  { name: "step_frequency", type: "float", doc: "single steps per second" },
  { name: "foot_lift", type: "float", doc: "swing foot apex above the ground, m" },
  { name: "max_acc_x", type: "float", doc: "forward acceleration limit, m/s^2" },
  { name: "trunk_pitch", type: "float", doc: "torso lean forward, rad" },
  { name: "imu_stabilization", type: "bool", doc: "torso pitch/roll feedback from imu/data" },
];
const found = (query) => WALKING.filter((p) => matches(query, "walking", p)).map((p) => p.name);

test("the dotted name the panel shows", () => {
  assert.deepEqual(found("walking.step"), ["step_frequency"]);
  assert.deepEqual(found("walking.step_frequency"), ["step_frequency"]);
  assert.deepEqual(found("step freq"), ["step_frequency"]);
  assert.deepEqual(found("hcm.step"), []);
});

test("words of the description", () => {
  assert.deepEqual(found("swing foot"), ["foot_lift"]);
  assert.deepEqual(found("torso lean"), ["trunk_pitch"]);
});

test("units, by name and by everyday word", () => {
  assert.deepEqual(found("m"), ["foot_lift"]); // a whole word: not every name with an m in it
  assert.deepEqual(found("m/s^2"), ["max_acc_x"]);
  assert.deepEqual(found("hz"), ["rate_hz"]);
  assert.deepEqual(found("walking speed"), ["rate_hz", "step_frequency"]);
  assert.deepEqual(found("angle"), ["trunk_pitch"]);
  assert.deepEqual(found("acceleration"), ["max_acc_x"]);
  assert.deepEqual(matches("angle", "hcm", { name: "upright_deg", doc: "" }), true);
});

test("an empty query finds everything, an unknown word nothing", () => {
  assert.equal(found("").length, WALKING.length);
  assert.deepEqual(found("kick"), []);
});
