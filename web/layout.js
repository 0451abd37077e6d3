// The panel grid the user arranges: order (drag a panel's title bar), width and height, hidden panels; remembered.

const KEY = "pitchside.layout";

export class Layout {
  constructor(grid, panels, ctx) {
    this.grid = grid;
    this.modules = new Map(panels.map((p) => [p.id, p]));
    this.ctx = ctx;
    this.live = new Map(); // id -> {section, instance}
    this.state = this._load();
    this.dragged = null;
  }

  defaults() {
    return { columns: 3, panels: [...this.modules.values()].map((p) => ({ id: p.id, w: p.size[0], h: p.size[1],
      hidden: !!p.hidden })) };
  }

  _load() {
    const fallback = this.defaults();
    try {
      const saved = JSON.parse(localStorage.getItem(KEY));
      if (!saved || !Array.isArray(saved.panels)) return fallback;
      const known = saved.panels.filter((p) => this.modules.has(p.id));
      for (const p of fallback.panels) if (!known.some((k) => k.id === p.id)) known.push(p); // new panels
      return { columns: saved.columns || fallback.columns, panels: known };
    } catch {
      return fallback;
    }
  }

  save() {
    localStorage.setItem(KEY, JSON.stringify(this.state));
  }

  reset() {
    localStorage.removeItem(KEY);
    this.state = this.defaults();
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

  render() {
    const cols = this.state.columns;
    this.grid.style.setProperty("--columns", cols);
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
        live = this._create(p);
        this.live.set(p.id, live);
      }
      live.section.style.gridColumn = `span ${Math.min(p.w, cols)}`;
      live.section.style.gridRow = `span ${p.h}`;
      // move only what is out of place: moving an element reloads the iframes (3D view, plots) inside it
      if (this.grid.children[i] !== live.section) this.grid.insertBefore(live.section, this.grid.children[i] ?? null);
      i++;
    }
    for (const live of this.live.values()) live.instance.resize?.();
    this.ctx.onLayout?.(this.state);
  }

  _create(p) {
    const module = this.modules.get(p.id);
    const section = document.createElement("section");
    section.className = "panel";
    section.dataset.panel = p.id;
    const header = document.createElement("header");
    header.draggable = true;
    header.innerHTML = `<h2></h2>
      <button data-act="left" title="move earlier">◀</button><button data-act="right" title="move later">▶</button>
      <button data-act="wider" title="wider (cycles)">↔</button><button data-act="taller" title="taller (cycles)">↕</button>
      <button data-act="hide" title="hide this panel">✕</button>`;
    header.querySelector("h2").textContent = module.title;
    header.addEventListener("click", (e) => {
      const act = e.target.dataset?.act;
      if (act) this._act(p.id, act);
    });
    header.addEventListener("dragstart", (e) => {
      this.dragged = p.id;
      section.classList.add("dragging");
      e.dataTransfer.setData("text/plain", p.id);
      e.dataTransfer.effectAllowed = "move";
    });
    header.addEventListener("dragend", () => {
      section.classList.remove("dragging");
      this.grid.querySelectorAll(".drop-target").forEach((el) => el.classList.remove("drop-target"));
    });
    section.addEventListener("dragover", (e) => {
      if (this.dragged && this.dragged !== p.id) { e.preventDefault(); section.classList.add("drop-target"); }
    });
    section.addEventListener("dragleave", () => section.classList.remove("drop-target"));
    section.addEventListener("drop", (e) => {
      e.preventDefault();
      section.classList.remove("drop-target");
      if (this.dragged) this.move(this.dragged, p.id);
      this.dragged = null;
    });
    const body = document.createElement("div");
    body.className = "panel-body";
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
    if (act === "left" && vi > 0) this.move(id, visible[vi - 1].id);
    else if (act === "right" && vi < visible.length - 1) this.move(id, visible[vi + 1].id);
    else {
      if (act === "wider") p.w = p.w >= this.state.columns ? 1 : p.w + 1;
      if (act === "taller") p.h = p.h >= 5 ? 1 : p.h + 1;
      if (act === "hide") p.hidden = true;
      this.save();
      this.render();
    }
  }
}
