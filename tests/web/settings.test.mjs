// node --test tests/web/: what the page saves (web/settings.js): one list of keys, bad or missing values read as
// the default, a storage that refuses writes never stops the page.
import { test } from "node:test";
import assert from "node:assert/strict";
import { KEYS, getJSON, getText, has, remove, setJSON, setText, useStorage } from "../../web/settings.js";

test("every key the page saves is listed once, under pitchside.", () => {
  const keys = Object.values(KEYS);
  assert.equal(new Set(keys).size, keys.length);
  for (const key of keys) assert.match(key, /^pitchside\./);
});

test("text and JSON round-trip; what was never saved reads as the default", () => {
  useStorage(null); // a fresh memory storage
  assert.equal(getText(KEYS.theme, "light"), "light");
  assert.equal(setText(KEYS.theme, "dark"), true);
  assert.equal(getText(KEYS.theme), "dark");
  setJSON(KEYS.camera, { ball_in_image: false });
  assert.deepEqual(getJSON(KEYS.camera, {}), { ball_in_image: false });
  assert.equal(has(KEYS.camera), true);
  remove(KEYS.camera);
  assert.equal(has(KEYS.camera), false);
  assert.deepEqual(getJSON(KEYS.camera, {}), {});
});

test("a value that does not parse reads as the default", () => {
  useStorage(null);
  setText(KEYS.layout + "lab", "{not json");
  assert.equal(getJSON(KEYS.layout + "lab", "fallback"), "fallback");
});

test("a storage that throws (off, full) reads defaults and reports writes as refused", () => {
  const broken = {
    getItem() { throw new Error("SecurityError"); },
    setItem() { throw new Error("QuotaExceededError"); },
    removeItem() { throw new Error("SecurityError"); },
    clear() {},
  };
  const before = useStorage(broken);
  try {
    assert.equal(getText(KEYS.focus, "robot1"), "robot1");
    assert.equal(setJSON(KEYS.animDraft + "robot1", { anim: {} }), false);
    assert.doesNotThrow(() => remove(KEYS.focus));
    assert.equal(has(KEYS.focus), false);
  } finally {
    useStorage(before);
  }
});
