// What the page saves in this browser, in one place: every key the page writes to localStorage is named here,
// with what it holds. A value that does not parse, or storage that is off or full (private windows, quota), reads
// as the default and never stops the page. Outside a browser (node --test) the settings live in memory.

/** The keys, each "pitchside." + name (+ an id where one exists per preset, robot or panel). */
export const KEYS = Object.freeze({
  focus: "pitchside.focus",           // the focused robot's id
  preset: "pitchside.preset",         // the layout preset last chosen
  theme: "pitchside.theme",           // "light" or "dark"
  layout: "pitchside.layout.",        // + preset id: that preset's panels as the user arranged them (JSON)
  legacyLayout: "pitchside.layout",   // the one layout of earlier versions: every panel, now the "all" preset
  camera: "pitchside.camera",         // the camera panel's marker classes switched on or off (JSON)
  animDraft: "pitchside.animDraft.",  // + robot id: the animation being edited and not yet saved (JSON)
  stateGraph: "pitchside.stateGraph.", // + panel id: the state machine the panel shows
});

/** @returns {Pick<Storage, "getItem" | "setItem" | "removeItem" | "clear">} */
function memoryStorage() {
  const map = new Map();
  return {
    getItem: (key) => (map.has(key) ? map.get(key) : null),
    setItem: (key, value) => { map.set(key, String(value)); },
    removeItem: (key) => { map.delete(key); },
    clear: () => map.clear(),
  };
}

/** @type {Pick<Storage, "getItem" | "setItem" | "removeItem" | "clear">} */
let storage = globalThis.localStorage ?? memoryStorage();

/** Uses another storage (tests); returns the one used before. */
export function useStorage(other) {
  const before = storage;
  storage = other ?? memoryStorage();
  return before;
}

/** The text saved under key, or fallback. @param {string} key @param {string} [fallback] @returns {string} */
export function getText(key, fallback = "") {
  try { return storage.getItem(key) ?? fallback; } catch { return fallback; }
}

/** Saves text under key; false when the storage refused it (off or full). @returns {boolean} */
export function setText(key, value) {
  try { storage.setItem(key, String(value)); return true; } catch { return false; }
}

/** The value saved as JSON under key, or fallback when there is none or it does not parse. */
export function getJSON(key, fallback = null) {
  const text = getText(key, "");
  if (!text) return fallback;
  try { return JSON.parse(text); } catch { return fallback; }
}

/** Saves value as JSON under key; false when the storage refused it. @returns {boolean} */
export function setJSON(key, value) {
  return setText(key, JSON.stringify(value));
}

/** Forgets key. @param {string} key */
export function remove(key) {
  try { storage.removeItem(key); } catch { /* storage off: nothing was saved */ }
}

/** Whether something is saved under key. @param {string} key @returns {boolean} */
export function has(key) {
  try { return storage.getItem(key) !== null; } catch { return false; }
}
