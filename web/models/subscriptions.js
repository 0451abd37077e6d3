// Who holds which stream, at what rate: panels take holds on (robot, topic) streams, the connection asks the
// server for the fastest rate any hold wants and withdraws a stream no hold wants any more. A panel that closes or
// hides releases its holds, so the server stops sending what nobody shows (a hidden camera costs no images).

/** @typedef {{op: "subscribe", robot: string, topic: string, max_hz: number}} SubscribeRequest */
/** @typedef {{op: "unsubscribe", robot: string, topic: string}} UnsubscribeRequest */
/** @typedef {SubscribeRequest | UnsubscribeRequest} Request */

/** The rate a stream is asked for: 0 (every message) if any hold wants all, else the fastest.
 * @param {Iterable<number>} rates @returns {number | undefined} undefined: no hold */
export function combinedRate(rates) {
  let best;
  for (const hz of rates) {
    if (hz === 0) return 0;
    best = best === undefined ? hz : Math.max(best, hz);
  }
  return best;
}

export class SubscriptionBook {
  constructor() {
    /** @type {Map<string, Map<number, number>>} "robot|topic" -> hold id -> max_hz (0: all) */
    this.holds = new Map();
    this.nextId = 1;
  }

  /** A new hold; returns its id and the request that puts it into effect (null: the server already sends
   * the stream at least this fast). @returns {{id: number, request: Request | null}} */
  hold(robot, topic, maxHz = 0) {
    const key = `${robot}|${topic}`;
    const before = this.rate(key);
    const id = this.nextId++;
    if (!this.holds.has(key)) this.holds.set(key, new Map());
    this.holds.get(key).set(id, Math.max(0, Number(maxHz) || 0));
    return { id, request: this._change(key, before) };
  }

  /** Ends a hold; returns the request that follows (a slower rate, an unsubscribe) or null. A hold released
   * twice changes nothing. @returns {Request | null} */
  release(id) {
    for (const [key, held] of this.holds) {
      if (!held.has(id)) continue;
      const before = this.rate(key);
      held.delete(id);
      if (!held.size) this.holds.delete(key);
      return this._change(key, before);
    }
    return null;
  }

  /** The rate "robot|topic" is asked for, undefined when nobody holds it. @returns {number | undefined} */
  rate(key) {
    const held = this.holds.get(key);
    return held ? combinedRate(held.values()) : undefined;
  }

  /** Every stream held, as the subscribe requests to send again after a reconnect. @returns {SubscribeRequest[]} */
  requests() {
    return [...this.holds.keys()].map((key) => /** @type {SubscribeRequest} */ (this._request(key)));
  }

  /** @returns {Request | null} */
  _change(key, before) {
    return this.rate(key) === before ? null : this._request(key);
  }

  /** @returns {Request} */
  _request(key) {
    const cut = key.indexOf("|"); // a robot id has no "|"; a topic might
    const robot = key.slice(0, cut), topic = key.slice(cut + 1);
    const hz = this.rate(key);
    return hz === undefined ? { op: "unsubscribe", robot, topic } : { op: "subscribe", robot, topic, max_hz: hz };
  }
}
