// node --test tests/web/: the parameter table's values (web/models/param_table.js): typed values from inputs,
// what a reset or revert writes, the status line.
import { test } from "node:test";
import assert from "node:assert/strict";
import { defaultsOf, describeValues, differing, find, pick, same, typedValue } from "../../web/models/param_table.js";

const PARAMS = [
  { name: "step_frequency", type: "float", value: 2.2, default: 1.8, range: [0.5, 4] },
  { name: "arm_swing", type: "float", value: 0, default: 0 },
  { name: "debug", type: "bool", value: true, default: false },
  { name: "mode", type: "str", value: "fast", default: "safe", choices: ["safe", "fast"] },
  { name: "joints", type: "list", value: [1, 2], default: [1, 2] },
];

test("an input's text in the parameter's type; an empty number is null; bad JSON throws", () => {
  assert.equal(typedValue(PARAMS[0], { value: " 2.5 " }), 2.5);
  assert.equal(typedValue(PARAMS[0], { value: "" }), null);
  assert.equal(typedValue(PARAMS[2], { checked: false, value: "on" }), false);
  assert.equal(typedValue(PARAMS[3], { value: '"safe"' }), "safe");
  assert.deepEqual(typedValue(PARAMS[4], { value: "[3, 4]" }), [3, 4]);
  assert.throws(() => typedValue(PARAMS[4], { value: "[3," }), SyntaxError);
  assert.equal(typedValue({ name: "x", type: "str", value: "" }, { value: "a b" }), "a b");
});

test("a reset writes only what differs from the defaults; lists compare by content", () => {
  assert.deepEqual(defaultsOf(PARAMS, "debug"), { debug: false });
  assert.deepEqual(differing(PARAMS, defaultsOf(PARAMS)), { step_frequency: 1.8, debug: false, mode: "safe" });
  assert.ok(same([1, 2], [1, 2]) && !same([1, 2], [2, 1]));
});

test("the status line names node.name = value; a parameter is found by node and name", () => {
  assert.equal(describeValues("walking", { step_frequency: 2.2, mode: "fast" }),
    'walking.step_frequency = 2.2, walking.mode = "fast"');
  assert.equal(find({ nodes: { walking: PARAMS } }, "walking", "debug"), PARAMS[2]);
  assert.equal(find({ nodes: {} }, "hcm", "debug"), undefined);
});

test("a field path into a message's data; a missing step is undefined", () => {
  const data = { angular_velocity: { x: 0, y: -1.5 } };
  assert.equal(pick(data, "angular_velocity/y"), -1.5);
  assert.equal(pick(data, "linear_acceleration/z"), undefined);
});
