// The page's hooks for the browser tests, the benches and the documentation's pictures: one object,
// window.pitchside, and only the names listed here go on it. The page never reads them back; they are views of
// a panel's own state (counts of what it drew, what it shows), so a test asks the page instead of guessing from
// pixels. A name not listed is refused, so this list stays the whole of it.

/** name -> what it holds. */
export const HOOKS = Object.freeze({
  store: "the page's Store (web/store.js): the newest frame per robot and topic, robots, focus",
  conn: "the Connection (web/connection.js): subscriptions held, frames received per kind",
  layout: "the Layout (web/layout.js): the preset, its panels, show/hide",
  config: "the server's /api/config as the page got it",
  schemas: "the server's /api/schemas (message constants, the topic table)",
  camera: "camera panel: images decoded, their size, markers drawn per class",
  relativeView: "relative view: the ball and obstacles drawn around the focused robot",
  fieldView: "field view: robots and balls drawn, frames drawn",
  params: "parameters panel: its state (rows, search, errors, writes under way)",
  animEditor: "animation editor: its state (the animation, selection, history, status)",
  plots: "plots panel: the topics chosen for plotting, the last error",
  nodeLog: "node log: the lines shown and the filter",
  teleop: "teleop panel: the command being sent",
  stateGraphs: "state graph panels by id: robot, state machine shown, scale",
});

/** The hooks object (window.pitchside), made on first use. */
export function hooks() {
  return (globalThis.pitchside ??= {});
}

/** Puts value on window.pitchside under a listed name; returns a function that takes it off again (if it is
 * still this value). */
export function expose(name, value) {
  if (!(name in HOOKS)) throw new Error(`${name} is not a listed test hook (web/test_hooks.js)`);
  hooks()[name] = value;
  return () => { if (hooks()[name] === value) delete hooks()[name]; };
}
