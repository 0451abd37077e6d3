// The top bar's layout controls: a button per preset, columns, "+ panel" for a hidden one, reset, export to a
// JSON file and import from one. The chosen preset goes into the address (web/view_state.js).

import { setOptions } from "./dom.js";
import { PRESETS, PRESET_IDS } from "./presets.js";

export function installLayoutControls({ layout, modules, bar, onPreset }) {
  const presets = bar.querySelector("#presets");
  presets.replaceChildren(...PRESET_IDS.map((id) => {
    const button = document.createElement("button");
    button.type = "button";
    button.dataset.preset = id;
    button.textContent = PRESETS[id].title;
    button.title = PRESETS[id].rows ? `${PRESETS[id].title} layout: fills the window` : "every panel; the page scrolls";
    button.addEventListener("click", () => layout.usePreset(id));
    return button;
  }));
  const columns = bar.querySelector("#columns-select");
  const addMenu = bar.querySelector("#add-panel");
  const status = bar.querySelector("#layout-status");
  const file = bar.querySelector("#layout-file");

  columns.addEventListener("change", () => layout.setColumns(Number(columns.value)));
  addMenu.addEventListener("change", () => { if (addMenu.value) layout.show(addMenu.value); });
  bar.querySelector("#layout-reset").addEventListener("click", () => layout.reset());
  bar.querySelector("#layout-export").addEventListener("click", () => {
    const blob = new Blob([JSON.stringify(layout.exported(), null, 2)], { type: "application/json" });
    const link = document.createElement("a");
    link.href = URL.createObjectURL(blob);
    link.download = `pitchside-layout-${layout.preset}.json`;
    link.click();
    setTimeout(() => URL.revokeObjectURL(link.href), 1000);
  });
  bar.querySelector("#layout-import").addEventListener("click", () => file.click());
  file.addEventListener("change", async () => {
    const chosen = file.files?.[0];
    file.value = "";
    if (!chosen) return;
    try {
      layout.imported(JSON.parse(await chosen.text()));
      status.textContent = `layout imported from ${chosen.name}`;
      status.classList.remove("bad");
    } catch (err) {
      status.textContent = `${chosen.name}: ${err.message}`; // nothing changed
      status.classList.add("bad");
    }
  });

  /** The controls follow the layout (called by the layout after every change). */
  return (state, preset) => {
    for (const button of presets.children) button.setAttribute("aria-pressed", String(button.dataset.preset === preset));
    const counts = [...new Set([2, 3, 4, 6, state.columns])].sort((a, b) => a - b);
    setOptions(columns, counts.map((n) => [String(n), String(n)]));
    columns.value = String(state.columns);
    setOptions(addMenu, [["", "+ panel"], ...state.panels.filter((x) => x.hidden)
      .map((p) => [p.id, modules.find((m) => m.id === p.id)?.title ?? p.id])]);
    onPreset(preset);
  };
}
