// node --test tests/web/: the layout's arrangement (web/layout.js) without a page: a saved or imported layout is
// made safe, each preset is remembered on its own (web/settings.js), a bad one falls back to the preset.
import { test } from "node:test";
import assert from "node:assert/strict";
import { Layout } from "../../web/layout.js";
import { PRESETS } from "../../web/presets.js";
import { KEYS, getJSON, setJSON, setText, useStorage } from "../../web/settings.js";

const MODULES = ["parameters", "animation", "robot3d", "hcm", "teleop", "plots", "node_log", "diagnostics", "field",
  "team"].map((id) => ({ id, size: [1, 1] }));

/** A layout that never draws (render is the DOM's part, not tested here). */
function layout(preset) {
  const l = new Layout(null, MODULES, {}, preset);
  l.render = () => {};
  return l;
}

test("a fresh Lab layout is the preset's own arrangement", () => {
  useStorage(null);
  const l = layout("lab");
  const shown = l.state.panels.filter((p) => !p.hidden).map((p) => p.id);
  assert.deepEqual(shown, PRESETS.lab.panels.map(([id]) => id));
  assert.equal(l.state.columns, PRESETS.lab.columns);
});

test("a saved layout is cleaned: unknown and repeated panels dropped, bad spans to 1, missing panels added", () => {
  useStorage(null);
  setJSON(KEYS.layout + "lab", { columns: 99, rows: 2, panels: [
    { id: "plots", w: 40, h: 2 }, { id: "plots", w: 1, h: 1 }, { id: "<img src=x>", w: 1, h: 1 }, null,
    { id: "hcm", w: 2, h: -1, hidden: 1 }] });
  const l = layout("lab");
  assert.equal(l.state.columns, PRESETS.lab.columns, "an out-of-range column count falls back");
  assert.equal(l.state.rows, 2);
  assert.deepEqual(l.state.panels.slice(0, 2), [{ id: "plots", w: 1, h: 2, hidden: false }, // a span out of range: 1
    { id: "hcm", w: 2, h: 1, hidden: true }]);
  assert.equal(l.state.panels.filter((p) => p.id === "plots").length, 1);
  assert.equal(l.state.panels.length, MODULES.length, "every known panel is there once");
});

test("each preset keeps its own arrangement; a reset forgets only the current one", () => {
  useStorage(null);
  const lab = layout("lab");
  lab.show("field");
  assert.equal(getJSON(KEYS.layout + "lab").panels.find((p) => p.id === "field").hidden, false);
  lab.usePreset("match");
  assert.equal(getJSON(KEYS.layout + "match"), null, "the match preset was not touched");
  lab.usePreset("lab");
  assert.equal(lab.state.panels.find((p) => p.id === "field").hidden, false, "the Lab's change came back");
  lab.reset();
  assert.equal(getJSON(KEYS.layout + "lab"), null);
  assert.equal(lab.state.panels.find((p) => p.id === "field").hidden, true);
});

test("stored text that is no layout, and an imported file that is none, fall back or are refused", () => {
  useStorage(null);
  setText(KEYS.layout + "lab", "{broken");
  const l = layout("lab");
  assert.deepEqual(l.state, l.defaults("lab"));
  assert.throws(() => l.imported({ panels: [] }), /not a pitchside layout file/);
  assert.throws(() => l.imported({ format: "pitchside-layout", panels: "no" }), /no list of panels/);
  const exported = l.exported();
  l.imported(exported);
  assert.deepEqual(l.exported(), exported, "an exported layout imports as it was");
});
