// The panel grid the user arranges: a preset (web/presets.js) chosen with one click, then order (drag a panel's
// title bar), width and height, hidden panels; each preset's arrangement remembered on its own, exported and
// imported as JSON. A preset with rows fills the window (no page scrolling); "All panels" scrolls.

import { KEYS, getText, remove, setJSON } from "./settings.js";
import { PRESETS, presetState } from "./presets.js";

const PREFIX = KEYS.layout; // + preset id: that preset as the user arranged it
const LEGACY = KEYS.legacyLayout; // the one layout of earlier versions: every panel, now the "all" preset
const FORMAT = "pitchside-layout";
const MAX_COLUMNS = 12, MAX_ROWS = 8, MAX_SPAN = 6;

export class Layout {
  constructor(grid, panels, ctx, preset = "all") {
    this.grid = grid;
    this.modules = new Map(panels.map((p) => [p.id, p]));
    this.ctx = ctx;
    this.live = new Map(); // id -> {section, instance}
    this.preset = PRESETS[preset] ? preset : "all";
    this.state = this._load(this.preset);
    this.dragged = null;
    this.maximised = null; // the panel shown over the whole grid, or null
  }

  defaults(preset = this.preset) {
    return presetState(preset, [...this.modules.values()]);
  }

  _load(preset) {
    const fallback = this.defaults(preset);
    try {
      const raw = getText(PREFIX + preset, "") || (preset === "all" ? getText(LEGACY, "") : "");
      return raw ? this._checked(JSON.parse(raw), preset) : fallback;
    } catch {
      return fallback;
    }
  }

  /** A layout from storage or a file, made safe: known panels only, spans and grid sizes within bounds; panels it
   * does not name (added to pitchside since) join as the preset has them. Throws an Error saying what is wrong. */
  _checked(saved, preset) {
    if (!saved || typeof saved !== "object" || !Array.isArray(saved.panels)) {
      throw new Error("not a pitchside layout (no list of panels)");
    }
    const int = (v, lo, hi, fallback) => (Number.isInteger(v) && v >= lo && v <= hi ? v : fallback);
    const fallback = this.defaults(preset);
    const columns = int(saved.columns, 1, MAX_COLUMNS, fallback.columns);
    const rows = int(saved.rows, 0, MAX_ROWS, fallback.rows);
    const seen = new Set();
    const panels = [];
    for (const p of saved.panels) {
      if (!p || typeof p.id !== "string" || !this.modules.has(p.id) || seen.has(p.id)) continue;
      seen.add(p.id);
      panels.push({ id: p.id, w: int(p.w, 1, MAX_COLUMNS, 1), h: int(p.h, 1, MAX_SPAN, 1), hidden: Boolean(p.hidden) });
    }
    for (const p of fallback.panels) if (!seen.has(p.id)) panels.push({ ...p }); // as the preset has them
    return { preset, columns, rows, panels };
  }

  save() {
    setJSON(PREFIX + this.preset, this.state);
  }

  /** One click: the preset as the user last left it (its own arrangement until reset). */
  usePreset(preset) {
    if (!PRESETS[preset] || preset === this.preset) return;
    this.preset = preset;
    this.state = this._load(preset);
    this.maximised = null;
    this.render();
  }

  /** The current preset back to its own arrangement. */
  reset() {
    remove(PREFIX + this.preset);
    if (this.preset === "all") remove(LEGACY);
    this.state = this.defaults();
    this.render();
  }

  /** The current arrangement as a file's content (JSON), for another laptop or later. */
  exported() {
    return { format: FORMAT, version: 1, ...this.state };
  }

  /** A file's layout becomes its preset's arrangement (the current preset's when it names none); Error if bad. */
  imported(data) {
    if (data?.format !== FORMAT) throw new Error(`not a pitchside layout file (format is not "${FORMAT}")`);
    const preset = PRESETS[data.preset] ? data.preset : this.preset;
    const state = this._checked(data, preset);
    this.preset = preset;
    this.state = state;
    this.save();
    this.render();
  }

  setColumns(n) {
    this.state.columns = n;
    this.save();
    this.render();
  }

  show(id) {
    const p = this.state.panels.find((x) => x.id === id);
    if (p) { p.hidden = false; this.save(); this.render(); }
  }

  /** The panel over the whole grid, or back into its place (the same panel again, or null). */
  toggleMaximise(id) {
    this.maximised = this.maximised === id || !this.live.has(id) ? null : id;
    const top = document.getElementById("topbar")?.getBoundingClientRect().bottom ?? 0;
    document.body.style.setProperty("--topbar-bottom", `${Math.max(0, top) + 8}px`);
    for (const [pid, live] of this.live) live.section.classList.toggle("maximised", pid === this.maximised);
    this.grid.classList.toggle("has-maximised", this.maximised !== null);
    for (const live of this.live.values()) live.instance.resize?.();
  }

  render() {
    const { columns: cols, rows } = this.state;
    this.grid.style.setProperty("--columns", cols);
    this.grid.style.setProperty("--rows", rows || 1);
    this.grid.classList.toggle("fit", rows > 0);
    document.body.classList.toggle("fit-layout", rows > 0);
    document.body.dataset.preset = this.preset;
    for (const [id, live] of this.live) {
      const p = this.state.panels.find((x) => x.id === id);
      if (!p || p.hidden) {
        live.instance.destroy?.();
        live.section.remove();
        this.live.delete(id);
      }
    }
    let i = 0;
    for (const p of this.state.panels) {
      if (p.hidden) continue;
      let live = this.live.get(p.id);
      if (!live) {
        live = this._create(p.id);
        this.live.set(p.id, live);
      }
      live.section.style.gridColumn = `span ${Math.min(p.w, cols)}`;
      live.section.style.gridRow = `span ${rows ? Math.min(p.h, rows) : p.h}`;
      // move only what is out of place: moving an element reloads the iframes (3D view, plots) inside it
      if (this.grid.children[i] !== live.section) this.grid.insertBefore(live.section, this.grid.children[i] ?? null);
      i++;
    }
    if (this.maximised && !this.live.has(this.maximised)) this.toggleMaximise(null);
    for (const live of this.live.values()) live.instance.resize?.();
    this.ctx.onLayout?.(this.state, this.preset);
  }

  _create(id) {
    const module = this.modules.get(id);
    const section = document.createElement("section");
    section.className = "panel";
    section.dataset.panel = id;
    const header = document.createElement("header");
    header.draggable = true;
    header.innerHTML = `<h2></h2>
      <button data-act="left" title="move earlier">◀</button><button data-act="right" title="move later">▶</button>
      <button data-act="wider" title="wider (cycles)">↔</button><button data-act="taller" title="taller (cycles)">↕</button>
      <button data-act="max" title="fill the window with this panel, or back (key: F)">□</button>
      <button data-act="hide" title="hide this panel">✕</button>`;
    header.querySelector("h2").textContent = module.title;
    for (const button of header.querySelectorAll("button")) button.setAttribute("aria-label", `${button.title}: ${module.title}`);
    header.addEventListener("click", (e) => {
      const act = /** @type {HTMLElement} */ (e.target).dataset?.act;
      if (act) this._act(id, act);
    });
    header.addEventListener("dragstart", (e) => {
      this.dragged = id;
      section.classList.add("dragging");
      e.dataTransfer.setData("text/plain", id);
      e.dataTransfer.effectAllowed = "move";
    });
    header.addEventListener("dragend", () => {
      section.classList.remove("dragging");
      this.grid.querySelectorAll(".drop-target").forEach((el) => el.classList.remove("drop-target"));
    });
    section.addEventListener("dragover", (e) => {
      if (this.dragged && this.dragged !== id) { e.preventDefault(); section.classList.add("drop-target"); }
    });
    section.addEventListener("dragleave", () => section.classList.remove("drop-target"));
    section.addEventListener("drop", (e) => {
      e.preventDefault();
      section.classList.remove("drop-target");
      if (this.dragged) this.move(this.dragged, id);
      this.dragged = null;
    });
    const body = document.createElement("div");
    body.className = "panel-body";
    // a panel scrolls: keyboard users reach and scroll it too (WCAG: scrollable regions are focusable)
    body.tabIndex = 0;
    body.setAttribute("role", "region");
    body.setAttribute("aria-label", module.title);
    section.append(header, body);
    let instance = {};
    try {
      instance = module.create(body, this.ctx) || {};
    } catch (err) {
      body.textContent = `panel failed: ${err}`;
      console.error(err);
    }
    return { section, instance };
  }

  /** Puts panel `id` where panel `before` is. */
  move(id, before) {
    const panels = this.state.panels;
    const from = panels.findIndex((x) => x.id === id);
    const [item] = panels.splice(from, 1);
    const to = panels.findIndex((x) => x.id === before);
    panels.splice(to < 0 ? panels.length : (from <= to ? to + 1 : to), 0, item);
    this.save();
    this.render();
  }

  _act(id, act) {
    const panels = this.state.panels;
    const i = panels.findIndex((x) => x.id === id);
    const p = panels[i];
    const visible = panels.filter((x) => !x.hidden);
    const vi = visible.indexOf(p);
    if (act === "max") this.toggleMaximise(id);
    else if (act === "left" && vi > 0) this.move(id, visible[vi - 1].id);
    else if (act === "right" && vi < visible.length - 1) this.move(id, visible[vi + 1].id);
    else {
      if (act === "wider") p.w = p.w >= this.state.columns ? 1 : p.w + 1;
      if (act === "taller") p.h = p.h >= (this.state.rows || 5) ? 1 : p.h + 1;
      if (act === "hide") p.hidden = true;
      this.save();
      this.render();
    }
  }
}
