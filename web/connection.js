// The browser side of server/protocol.py: one WebSocket, subscriptions re-sent after a reconnect. Panels hold
// streams (web/models/subscriptions.js) and release them when they close or hide: the server then stops sending.

import { SubscriptionBook } from "./models/subscriptions.js";

export class Connection {
  constructor(url, onFrame, onStatus) {
    this.url = url;
    this.onFrame = onFrame;        // (frame) for JSON frames; images arrive as {type:"image", ..., blob}
    this.onStatus = onStatus;      // (connected: boolean)
    this.book = new SubscriptionBook();
    this.ws = null;
    this.connected = false;
    this.received = 0;
    this.counts = { images: 0, robots: 0, messages: 0 }; // frames received by kind (for tests: a hidden camera)
    this._open();
  }

  _open() {
    const ws = new WebSocket(this.url);
    ws.binaryType = "arraybuffer";
    this.ws = ws;
    ws.onopen = () => {
      this.connected = true;
      this.onStatus(true);
      for (const request of this.book.requests()) this._send(request);
    };
    ws.onmessage = (event) => {
      this.received++;
      if (typeof event.data === "string") {
        const frame = JSON.parse(event.data);
        if (frame.type === "batch") for (const f of frame.frames) this._take(f);
        else this._take(frame);
      } else {
        this.counts.images++;
        this.onFrame(splitBinary(event.data));
      }
    };
    ws.onclose = () => {
      this.connected = false;
      this.onStatus(false);
      setTimeout(() => this._open(), 1000);
    };
  }

  _take(frame) {
    if (frame.type === "robots") this.counts.robots++;
    else this.counts.messages++;
    this.onFrame(frame);
  }

  _send(request) {
    if (request && this.connected) this.ws.send(JSON.stringify(request));
  }

  /** Holds a stream at most maxHz (0 = unthinned); the server sends the fastest rate held. Returns the release:
   * once every hold on a stream is released, the server stops sending it. */
  subscribe(robot, topic, maxHz = 0) {
    const { id, request } = this.book.hold(robot, topic, maxHz);
    this._send(request);
    return () => this._send(this.book.release(id));
  }
}

/** uint32 big-endian N | N bytes JSON meta | payload (see server/protocol.py). */
export function splitBinary(buffer) {
  const n = new DataView(buffer).getUint32(0, false);
  const meta = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, n)));
  meta.blob = new Blob([new Uint8Array(buffer, 4 + n)], { type: `image/${meta.format || "jpeg"}` });
  return meta;
}
