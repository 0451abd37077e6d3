// node --test tests/web/: the page's store (web/store.js) outside a browser: the newest frame per stream, the focus
// it remembers through web/settings.js, and pausing the live view without losing events.
import { test } from "node:test";
import assert from "node:assert/strict";
import { Store } from "../../web/store.js";
import { KEYS, getText, useStorage } from "../../web/settings.js";

const msg = (robot, topic, stamp, data = {}) => ({ type: "msg", robot, topic, stamp, data });

test("the newest frame of each robot's stream, and topic listeners called per frame", () => {
  useStorage(null);
  const store = new Store();
  const seen = [];
  const off = store.on("topic:gamestate", (f) => seen.push(f.stamp));
  store.handle(msg("r1", "gamestate", 1));
  store.handle(msg("r1", "gamestate", 2));
  store.handle(msg("r2", "robot_state", 3));
  off();
  store.handle(msg("r1", "gamestate", 4));
  assert.deepEqual(seen, [1, 2]);
  assert.equal(store.get("r1", "gamestate").stamp, 4);
  assert.equal(store.get("r2", "robot_state").stamp, 3);
  assert.equal(store.get("r3", "gamestate"), undefined);
});

test("the focused robot is saved and read back by a new page", () => {
  useStorage(null);
  const store = new Store();
  const focused = [];
  store.on("focus", (robot) => focused.push(robot));
  store.setFocus("robot2");
  store.setFocus("robot2");
  assert.deepEqual(focused, ["robot2"], "the same focus again is no news");
  assert.equal(getText(KEYS.focus), "robot2");
  assert.equal(new Store().focus, "robot2");
});

test("paused, frames are held (events all) and shown on resume", () => {
  useStorage(null);
  const store = new Store(new Set(["speak"]));
  store.pause();
  store.handle(msg("r1", "speak", 1, { text: "a" }));
  store.handle(msg("r1", "speak", 2, { text: "b" }));
  assert.equal(store.get("r1", "speak"), undefined, "nothing shown while paused");
  const spoken = [];
  store.on("topic:speak", (f) => spoken.push(f.data.text));
  store.resume();
  assert.deepEqual(spoken, ["a", "b"]);
  assert.equal(store.paused, false);
});
