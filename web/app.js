// The dashboard page: one connection, one store, panels in a layout the user arranges.

import { Connection } from "./connection.js";
import { setOptions } from "./dom.js";
import { SessionBar } from "./session.js";
import { Layout } from "./layout.js";
import { PlaybackBar } from "./playback_bar.js";
import { eventTopics, learnSchemas } from "./msgtypes.js";
import { Store } from "./store.js";
import teamOverview from "./panels/team_overview.js";
import fieldView from "./panels/field_view.js";
import relativeView from "./panels/relative_view.js";
import hcmGraph from "./panels/hcm_graph.js";
import camera from "./panels/camera.js";
import robot3d from "./panels/robot3d.js";
import plots from "./panels/plots.js";
import diagnostics from "./panels/diagnostics.js";
import parameters from "./panels/parameters.js";
import animationEditor from "./panels/animation_editor.js";
import teleop from "./panels/teleop.js";
import replay from "./panels/replay.js";
import recordings from "./panels/recordings.js";
import nodeLog from "./panels/node_log.js";

const PANELS = [teamOverview, fieldView, relativeView, hcmGraph, camera, diagnostics, robot3d, plots, parameters,
  animationEditor, teleop, replay, recordings, nodeLog];

async function main() {
  // the message constants and the topic table come from the server (the .msg files), before any panel starts
  const [config, schemas] = await Promise.all(["api/config", "api/schemas"]
    .map(async (path) => (await fetch(path)).json()));
  learnSchemas(schemas);
  const store = new Store(eventTopics());
  const status = document.getElementById("link-status");
  const wsUrl = `${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`;
  const conn = new Connection(wsUrl, (frame) => store.handle(frame), (up) => {
    status.textContent = up ? "connected" : "disconnected";
    status.className = `badge ${up ? "ok" : "bad"}`;
  });
  document.getElementById("match-badge").hidden = !config.match_mode;
  new SessionBar(document.getElementById("session"), config);

  const ctx = {
    store, conn, config,
    /** Subscribe a panel to a topic of every robot, at most maxHz; fn(frame) on every arrival. */
    subscribe(topic, maxHz, fn) {
      conn.subscribe("*", topic, maxHz);
      return store.on(`topic:${topic}`, fn);
    },
    onLayout: (state) => {
      document.getElementById("columns-select").value = String(state.columns);
      refreshAddMenu(state);
    },
  };
  const layout = new Layout(document.getElementById("grid"), PANELS, ctx);
  window.pitchside = { store, conn, layout, config, schemas };
  new PlaybackBar(document.body, store);
  store.on("replay-opened", () => { // a log opened (from the recordings list): bring the replay view into sight
    layout.show("replay");
    layout.live.get("replay")?.section.scrollIntoView({ behavior: "smooth", block: "nearest" });
  });

  const addMenu = document.getElementById("add-panel");
  function refreshAddMenu(state) {
    setOptions(addMenu, [["", "+ panel"], ...state.panels.filter((x) => x.hidden)
      .map((p) => [p.id, PANELS.find((m) => m.id === p.id)?.title ?? p.id])]);
  }
  addMenu.addEventListener("change", () => { if (addMenu.value) layout.show(addMenu.value); });
  document.getElementById("columns-select").addEventListener("change", (e) => layout.setColumns(+e.target.value));
  document.getElementById("layout-reset").addEventListener("click", () => layout.reset());
  const root = document.documentElement;
  if (localStorage.getItem("pitchside.theme") === "dark") root.classList.add("dark");
  document.getElementById("theme-toggle").addEventListener("click", () => {
    root.classList.toggle("dark");
    localStorage.setItem("pitchside.theme", root.classList.contains("dark") ? "dark" : "light");
    store.emit("theme");
  });

  const focusSelect = document.getElementById("focus-select");
  function refreshFocus() {
    setOptions(focusSelect, store.robotIds().map((id) => [id, id]));
    focusSelect.value = store.focus;
  }
  store.on("robots", refreshFocus);
  store.on("focus", refreshFocus);
  focusSelect.addEventListener("change", () => store.setFocus(focusSelect.value));
  layout.render();
  window.addEventListener("resize", () => { for (const l of layout.live.values()) l.instance.resize?.(); });
}

main();
