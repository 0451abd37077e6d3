// Keyboard: 1-9 focus a robot, F fills the window with the panel under the mouse (F or Escape: back), space
// pauses the live view (data keeps arriving and is shown on resume), ? lists the shortcuts.

export const SHORTCUTS = [
  ["1 … 9", "focus robot 1 … 9 (in the order of the focus list)"],
  ["F", "fill the window with the panel under the mouse; F or Esc again: back"],
  ["Space", "pause the live view (data keeps arriving, shown on resume); again: resume"],
  ["?", "show or hide these shortcuts"],
  ["Esc", "close this list, or a panel filling the window"],
];

/** Keys typed into a field, a menu or a control with keys of its own (teleop's pad) are theirs, not ours. */
function theirs(e) {
  const el = e.target;
  return e.defaultPrevented || e.ctrlKey || e.altKey || e.metaKey
    || (el instanceof Element && el.closest("input, textarea, select, [contenteditable], .joystick, .playback-track"));
}

export function installShortcuts({ store, layout, help }) {
  let pointed = null; // the panel under the mouse
  document.addEventListener("mousemove", (e) => { pointed = e.target instanceof Element ? e.target.closest("section.panel") : null; },
    { passive: true });
  const list = help.querySelector(".shortcut-list");
  list.replaceChildren(...SHORTCUTS.flatMap(([key, what]) => {
    const dt = document.createElement("dt");
    const kbd = document.createElement("kbd");
    kbd.textContent = key;
    dt.append(kbd);
    const dd = document.createElement("dd");
    dd.textContent = what;
    return [dt, dd];
  }));
  help.querySelector(".close").addEventListener("click", () => help.close());

  document.addEventListener("keydown", (e) => {
    if (theirs(e)) return;
    if (e.key === "?") {
      e.preventDefault();
      if (help.open) help.close(); else help.showModal();
    } else if (help.open) {
      return; // the dialog has the keys (Esc closes it)
    } else if (/^[1-9]$/.test(e.key)) {
      const robot = store.robotIds()[Number(e.key) - 1];
      if (robot) store.setFocus(robot);
    } else if (e.key === "f" || e.key === "F") {
      const id = layout.maximised ?? pointed?.dataset.panel;
      if (id) layout.toggleMaximise(id);
    } else if (e.key === "Escape" && layout.maximised) {
      layout.toggleMaximise(layout.maximised);
    } else if (e.key === " ") {
      e.preventDefault(); // neither scroll nor press the button that has the focus
      if (store.paused) store.resume(); else store.pause();
    }
  });
}
