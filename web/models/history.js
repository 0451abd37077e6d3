// Undo and redo as command objects in one bounded history (as the three.js editor keeps it): each command knows
// how to do and undo itself; the oldest steps go once the history is full, so a long session holds bounded memory.

/** @typedef {{label: string, execute: () => void, undo: () => void}} Command */

export const HISTORY_LIMIT = 200; // steps kept; an animation's step is two JSON texts of a few kB

export class History {
  /** @param {number} [limit] */
  constructor(limit = HISTORY_LIMIT) {
    if (!Number.isInteger(limit) || limit < 1) throw new RangeError(`a history keeps at least 1 step, not ${limit}`);
    this.limit = limit;
    /** @type {Command[]} */
    this.done = [];
    /** @type {Command[]} */
    this.undone = [];
  }

  /** Runs the command and keeps it for undo; whatever was undone before cannot be redone any more.
   * @param {Command} command */
  execute(command) {
    command.execute();
    this.record(command);
  }

  /** Keeps a command that has already been applied (an edit typed into a field). @param {Command} command */
  record(command) {
    this.done.push(command);
    if (this.done.length > this.limit) this.done.shift();
    this.undone = [];
  }

  /** Undoes the newest step; returns it, or null when there is nothing to undo. The step is moved to the redo
   * side before it runs, so what it redraws sees the history as it will be; a step that throws stays where it was.
   * @returns {Command | null} */
  undo() {
    return this._step(this.done, this.undone, (command) => command.undo());
  }

  /** Does the newest undone step again; returns it, or null. @returns {Command | null} */
  redo() {
    return this._step(this.undone, this.done, (command) => command.execute());
  }

  /** @param {Command[]} from @param {Command[]} to @param {(command: Command) => void} run */
  _step(from, to, run) {
    const command = from.pop();
    if (!command) return null;
    to.push(command);
    try {
      run(command);
    } catch (err) {
      to.pop();
      from.push(command);
      throw err;
    }
    return command;
  }

  /** Forgets every step (another file opened). */
  clear() {
    this.done = [];
    this.undone = [];
  }

  get canUndo() { return this.done.length > 0; }
  get canRedo() { return this.undone.length > 0; }
}

/** A command that swaps one whole value for another (an animation before and after an edit, as JSON text).
 * @param {string} label @param {string} before @param {string} after @param {(text: string) => void} show
 * @returns {Command} */
export function replaceCommand(label, before, after, show) {
  return { label, execute: () => show(after), undo: () => show(before) };
}
