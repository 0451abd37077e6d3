// The page's one way to put text from outside into HTML: robot ids, topics, node names and strings in messages
// come from the network or from files, so every value written into markup goes through esc(), or into the DOM
// as a text node (textContent, new Option). The page's Content-Security-Policy refuses inline script as a
// second line of defence.

const ENTITIES = { "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" };

/** Text (or a number) made safe for HTML content and quoted attribute values. */
export function esc(value) {
  return String(value ?? "").replace(/[&<>"']/g, (c) => ENTITIES[c]);
}

/** Replaces a <select>'s options by [value, label] pairs as DOM nodes (text, never markup); true if changed. */
export function setOptions(select, pairs) {
  const have = [...select.options].map((o) => [o.value, o.textContent]);
  if (have.length === pairs.length && have.every(([v, t], i) => v === pairs[i][0] && t === pairs[i][1])) return false;
  select.replaceChildren(...pairs.map(([value, label]) => new Option(label, value)));
  return true;
}

/** A lab tool's status line: set(text, bad) shows the text as text and marks a failure "bad"; onBad hears failures. */
/** @param {HTMLElement} el @param {(text: string) => void} [onBad] */
export function statusLine(el, onBad = () => {}) {
  return (text, bad = false) => {
    el.textContent = text;
    el.classList.toggle("bad", bad);
    if (bad) onBad(text);
  };
}
