// node --test tests/web/: undo and redo as command objects in a bounded history (web/models/history.js), as the
// animation editor uses it.
import { test } from "node:test";
import assert from "node:assert/strict";
import { History, replaceCommand } from "../../web/models/history.js";

/** A value edited through replace commands, as the editor edits its animation (JSON text). */
function editor(limit) {
  const ed = { text: "0", history: new History(limit) };
  ed.set = (next) => ed.history.execute(replaceCommand(`set ${next}`, ed.text, next, (t) => { ed.text = t; }));
  return ed;
}

test("undo and redo walk the steps back and forth; a new edit drops what was undone", () => {
  const ed = editor();
  ed.set("1"); ed.set("2"); ed.set("3");
  assert.equal(ed.history.undo().label, "set 3");
  assert.equal(ed.text, "2");
  ed.history.undo();
  assert.equal(ed.text, "1");
  ed.history.redo();
  assert.equal(ed.text, "2");
  ed.set("x");
  assert.equal(ed.history.canRedo, false);
  assert.equal(ed.history.redo(), null);
  ed.history.undo(); ed.history.undo(); ed.history.undo();
  assert.equal(ed.text, "0");
  assert.equal(ed.history.undo(), null, "nothing left to undo");
});

test("the history is bounded: the oldest steps go first", () => {
  const ed = editor(3);
  for (const v of ["1", "2", "3", "4", "5"]) ed.set(v);
  assert.equal(ed.history.done.length, 3);
  while (ed.history.undo());
  assert.equal(ed.text, "2", "the steps from 0 to 1 and 1 to 2 were dropped");
});

test("an edit already applied is recorded without running it again", () => {
  const history = new History();
  let runs = 0;
  history.record({ label: "typed", execute: () => { runs++; }, undo: () => { runs--; } });
  assert.equal(runs, 0);
  history.undo();
  assert.equal(runs, -1);
  history.redo();
  assert.equal(runs, 0);
});

test("clear forgets every step; a limit below one is refused", () => {
  const ed = editor();
  ed.set("1");
  ed.history.undo();
  ed.history.clear();
  assert.equal(ed.history.canUndo || ed.history.canRedo, false);
  assert.throws(() => new History(0), RangeError);
});

test("while a step runs, the history already shows it moved (what it redraws sees the buttons' new state)", () => {
  const history = new History();
  const seen = [];
  const command = { label: "x", execute: () => seen.push([history.canUndo, history.canRedo]),
    undo: () => seen.push([history.canUndo, history.canRedo]) };
  history.record(command);
  history.undo();
  history.redo();
  assert.deepEqual(seen, [[false, true], [true, false]]);
});

test("a step that throws stays where it was", () => {
  const history = new History();
  history.record({ label: "bad", execute: () => {}, undo: () => { throw new Error("no"); } });
  assert.throws(() => history.undo(), /no/);
  assert.equal(history.canUndo, true);
  assert.equal(history.canRedo, false);
});
