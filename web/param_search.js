// Finding a parameter as a person names it: by the dotted name the panel shows ("walking.step" finds
// walking.step_frequency), by words of its description, and by what it measures: its unit, from the name's suffix
// (rate_hz, period_s, upright_deg) or the description ("..., m", "rad/s^2", "per second"), and a few everyday words
// for a unit ("speed" finds what is per second, "angle" what is in rad or deg). Pure: no DOM, tested with node --test.

// the unit words a parameter's name suffix stands for
const SUFFIX_UNITS = { hz: ["hz", "per second"], s: ["s", "seconds"], ms: ["ms", "milliseconds"], m: ["m", "metres"],
  deg: ["deg", "degrees"], rad: ["rad", "radians"], mm: ["mm"], pct: ["%", "percent"] };

// everyday words for what a unit measures: a query word matches a parameter that holds any of them
const MEANS = {
  speed: ["speed", "velocity", "frequency", "per second", "m/s", "rad/s", "hz"],
  fast: ["speed", "velocity", "frequency", "per second", "m/s", "rad/s", "hz"],
  rate: ["rate", "frequency", "per second", "hz"],
  frequency: ["frequency", "per second", "hz"],
  time: ["time", "seconds", "s", "ms", "duration", "period"],
  duration: ["duration", "seconds", "s", "ms", "time"],
  angle: ["angle", "rad", "deg", "radians", "degrees"],
  distance: ["distance", "m", "metres", "mm", "length"],
  length: ["length", "m", "metres", "mm", "distance"],
  acceleration: ["acceleration", "m/s^2", "rad/s^2"],
};

/** The words of a text, lower case: split at spaces, commas, brackets and underscores; "m/s" stays one word. */
export function words(text) {
  return String(text ?? "").toLowerCase().split(/[\s,;()[\]_]+/).map((w) => w.replace(/^[.:]+|[.:]+$/g, ""))
    .filter(Boolean);
}

/** What a search looks through for one parameter: its dotted name, name words, description, type and units. */
export function searchText(node, p) {
  const suffix = String(p.name).toLowerCase().split("_").at(-1);
  const units = SUFFIX_UNITS[suffix] ?? [];
  const doc = String(p.doc ?? "");
  return {
    dotted: `${node}.${p.name}`.toLowerCase(),
    words: new Set([...words(node), ...words(p.name), ...words(doc), ...words(p.type), ...units]),
    text: `${node}.${p.name} ${String(p.name).replaceAll("_", " ")} ${doc} ${units.join(" ")}`.toLowerCase(),
  };
}

/** Does one query word name this parameter? Short words (1-2 letters, units like "m" or "s") and words with a
 * slash ("m/s") must be whole words; longer ones may be part of a word ("freq" in frequency); a dotted word is a
 * part of the dotted name. */
function wordMatches(hay, word) {
  const alike = (w) => (w.length <= 2 || w.includes("/") ? hay.words.has(w) : hay.text.includes(w));
  if (word.includes(".")) return hay.dotted.includes(word) || hay.text.includes(word);
  return alike(word) || (MEANS[word] ?? []).some(alike);
}

/** True when every word of the query names the parameter (an empty query matches everything). */
export function matches(query, node, p) {
  const asked = String(query ?? "").toLowerCase().split(/\s+/).filter(Boolean);
  if (!asked.length) return true;
  const hay = searchText(node, p);
  return asked.every((w) => wordMatches(hay, w));
}
