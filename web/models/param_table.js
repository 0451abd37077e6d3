// The parameter table's values without the page: a typed value from what an input holds, what a reset or revert
// would change, the line the status shows. The panel (web/panels/parameters.js) draws and sends; this decides.

/** @typedef {{name: string, type: string, value: any, default?: any, choices?: any[], range?: number[],
 *   startup?: boolean, revision?: number, description?: string}} Param */

/** The value at a field path ("angular_velocity/y") of a message's data; undefined when a step is missing. */
export function pick(obj, path) {
  return path.split("/").reduce((o, k) => (o == null ? undefined : o[k]), obj);
}

/** Two parameter values are the same (lists compared by content). */
export function same(a, b) { return JSON.stringify(a) === JSON.stringify(b); }

/** A parameter of a node's list, by name. @param {{nodes: Record<string, Param[]>}} state */
export function find(state, node, name) { return state.nodes[node]?.find((p) => p.name === name); }

/** The value an input holds, in the parameter's type: a toggle's state, a choice or a list as JSON (throws when it
 * is none), a number (null when empty), else the text. @param {Param} p
 * @param {{checked?: boolean, value: string}} input */
export function typedValue(p, input) {
  if (p.type === "bool") return Boolean(input.checked);
  if (p.choices) return JSON.parse(input.value);
  if (p.type === "int" || p.type === "float") return input.value.trim() === "" ? null : Number(input.value);
  if (p.type === "list") return JSON.parse(input.value);
  return input.value;
}

/** "node.name = value, ..." for the status line and the confirmations. */
export function describeValues(node, values) {
  return Object.entries(values).map(([name, v]) => `${node}.${name} = ${JSON.stringify(v)}`).join(", ");
}

/** The targets ({name: value}) that differ from the node's values now: what a reset or revert has to write.
 * @param {Param[]} params */
export function differing(params, targets) {
  return Object.fromEntries(Object.entries(targets)
    .filter(([n, v]) => !same(params.find((p) => p.name === n)?.value, v)));
}

/** A node's defaults ({name: default}), all or of the named parameter. @param {Param[]} params */
export function defaultsOf(params, name = "") {
  return Object.fromEntries(params.filter((p) => !name || p.name === name).map((p) => [p.name, p.default]));
}
