// The layouts one click away: which panels a task needs and how large, on a grid that fills the window.
// Match, Lab and Replay each fit a 1920x1080 screen without page scrolling (tests/test_presets_browser.py);
// "All panels" is every panel in a scrolling grid. A new panel joins a preset with one line here.

/** id -> {title, columns, rows (0: rows grow, the page scrolls), panels: [[panel id, width, height], ...]}. */
export const PRESETS = {
  match: {
    title: "Match", key: "M", columns: 4, rows: 3,
    panels: [["field", 2, 2], ["team", 2, 2], ["game", 1, 1], ["links", 2, 1], ["recordings", 1, 1]],
  },
  // the effect of a change in sight: the focused robot's HCM state, its nodes' log and their diagnostics
  lab: {
    title: "Lab", key: "L", columns: 4, rows: 4,
    panels: [["parameters", 1, 3], ["animation", 2, 3], ["robot3d", 1, 2], ["hcm", 1, 1], ["teleop", 1, 1],
      ["plots", 1, 1], ["node_log", 1, 1], ["diagnostics", 1, 1]],
  },
  replay: {
    title: "Replay", key: "R", columns: 6, rows: 3,
    // the robot cards: the REPLAY badge says which robots are the log's (the HCM graph keeps its width: readable)
    panels: [["field", 3, 2], ["hcm", 3, 2], ["replay", 2, 1], ["recordings", 1, 1], ["team", 1, 1], ["plots", 1, 1],
      ["robot3d", 1, 1]],
  },
  all: { title: "All panels", key: "A", columns: 3, rows: 0, panels: null }, // every panel at its own size
};

export const PRESET_IDS = Object.keys(PRESETS);

/** The preset a page opens with when neither the address nor the user chose one. */
export function startPreset(config) {
  return config.match_mode ? "match" : "lab";
}

/** A preset's own arrangement of the known panel modules: listed panels first in its order, the rest hidden. */
export function presetState(id, modules) {
  const preset = PRESETS[id];
  if (!preset.panels) {
    return { preset: id, columns: preset.columns, rows: 0, panels: modules.map((m) => ({ id: m.id, w: m.size[0],
      h: m.size[1], hidden: Boolean(m.hidden) })) };
  }
  const listed = preset.panels.filter(([pid]) => modules.some((m) => m.id === pid))
    .map(([pid, w, h]) => ({ id: pid, w, h, hidden: false }));
  const rest = modules.filter((m) => !listed.some((p) => p.id === m.id))
    .map((m) => ({ id: m.id, w: Math.min(m.size[0], preset.columns), h: 1, hidden: true }));
  return { preset: id, columns: preset.columns, rows: preset.rows, panels: [...listed, ...rest] };
}
