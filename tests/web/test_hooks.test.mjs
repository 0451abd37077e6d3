// node --test tests/web/: the test hooks are one object with a listed set of names (web/test_hooks.js).
import { test } from "node:test";
import assert from "node:assert/strict";
import { HOOKS, expose, hooks } from "../../web/test_hooks.js";

test("a listed name goes on the one hooks object and comes off again", () => {
  const stats = { images: 0 };
  const withdraw = expose("camera", stats);
  assert.equal(hooks().camera, stats);
  assert.equal(globalThis.pitchside, hooks());
  withdraw();
  assert.equal("camera" in hooks(), false);
});

test("a later value under the same name is not taken off by the earlier one's withdraw", () => {
  const withdrawOld = expose("plots", { n: 1 });
  const newer = { n: 2 };
  expose("plots", newer);
  withdrawOld();
  assert.equal(hooks().plots, newer);
});

test("a name not listed is refused, and every listed name says what it holds", () => {
  assert.throws(() => expose("secretPanel", {}), /not a listed test hook/);
  for (const [name, what] of Object.entries(HOOKS)) assert.ok(what.length > 10, name);
});
