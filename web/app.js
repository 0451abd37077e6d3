// The dashboard page: one connection, one store, panels in a layout the user arranges.

import { expose } from "./test_hooks.js";
import { KEYS, getText, setText } from "./settings.js";
import { Connection } from "./connection.js";
import { setOptions } from "./dom.js";
import { SessionBar } from "./session.js";
import { Layout } from "./layout.js";
import { installLayoutControls } from "./layout_controls.js";
import { PRESETS, startPreset } from "./presets.js";
import { installShortcuts } from "./shortcuts.js";
import { installTheme } from "./theme.js";
import { showInAddress, viewFromAddress } from "./view_state.js";
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
import gameState from "./panels/game_state.js";
import linkHealth from "./panels/link_health.js";
import ros2Robots from "./panels/ros2_robots.js";

const PANELS = [teamOverview, fieldView, relativeView, hcmGraph, camera, diagnostics, robot3d, plots, parameters,
  animationEditor, teleop, replay, recordings, nodeLog, gameState, linkHealth, ros2Robots];
const PRESET_KEY = KEYS.preset;

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

  // the view: the address first (a shared link), then what this browser used last, then the server's mode
  const asked = viewFromAddress();
  if (asked.robot) store.setFocus(asked.robot);
  const preset = [asked.preset, getText(PRESET_KEY)].find((p) => PRESETS[p]) ?? startPreset(config);

  /** @type {(state: object, chosen: string) => void} */
  let followLayout = () => {};
  const ctx = {
    store, conn, config,
    /** Subscribe a panel to a topic of every robot, at most maxHz; fn(frame) on every arrival. The returned
     * function ends both: a panel calls it when it closes or hides, and the server stops sending. */
    subscribe(topic, maxHz, fn) {
      const release = conn.subscribe("*", topic, maxHz);
      const off = store.on(`topic:${topic}`, fn);
      return () => { off(); release(); };
    },
    onLayout: (state, chosen) => followLayout(state, chosen),
  };
  const layout = new Layout(document.getElementById("grid"), PANELS, ctx, preset);
  for (const [name, value] of Object.entries({ store, conn, layout, config, schemas })) expose(name, value);
  followLayout = installLayoutControls({ layout, modules: PANELS, bar: document.getElementById("topbar"),
    onPreset: (chosen) => { setText(PRESET_KEY, chosen); showInAddress(chosen, store.focus); } });
  new PlaybackBar(document.body, store);
  store.on("replay-opened", () => { // a log opened (from the recordings list): bring the replay view into sight
    layout.show("replay");
    layout.live.get("replay")?.section.scrollIntoView({ behavior: "smooth", block: "nearest" });
  });
  installTheme(document.getElementById("theme-toggle"), () => store.emit("theme"));

  const focusSelect = /** @type {HTMLSelectElement} */ (document.getElementById("focus-select"));
  function refreshFocus() {
    setOptions(focusSelect, store.robotIds().map((id) => [id, id]));
    focusSelect.value = store.focus;
  }
  store.on("robots", refreshFocus);
  store.on("focus", () => { refreshFocus(); showInAddress(layout.preset, store.focus); });
  focusSelect.addEventListener("change", () => store.setFocus(focusSelect.value));

  const pause = document.getElementById("pause-live");
  const showPause = () => {
    pause.textContent = store.paused ? `PAUSED · ${store.held.length + store.heldDropped} new` : "live";
    pause.className = `badge ${store.paused ? "warn" : "ok"}`;
    pause.setAttribute("aria-pressed", String(store.paused));
  };
  pause.addEventListener("click", () => (store.paused ? store.resume() : store.pause()));
  store.on("paused", showPause);
  setInterval(() => { if (store.paused) showPause(); }, 500);
  showPause();
  const help = /** @type {HTMLDialogElement} */ (document.getElementById("shortcuts"));
  installShortcuts({ store, layout, help });
  document.getElementById("shortcuts-button").addEventListener("click", () => help.showModal());

  layout.render();
  window.addEventListener("resize", () => { for (const l of layout.live.values()) l.instance.resize?.(); });
}

main();
