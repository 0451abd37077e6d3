// The browser side of server/protocol.py: one WebSocket, subscriptions re-sent after a reconnect.

export class Connection {
  constructor(url, onFrame, onStatus) {
    this.url = url;
    this.onFrame = onFrame;        // (frame) for JSON frames; images arrive as {type:"image", ..., blob}
    this.onStatus = onStatus;      // (connected: boolean)
    this.subscriptions = new Map(); // "robot|topic" -> max_hz (0: all)
    this.ws = null;
    this.connected = false;
    this.received = 0;
    this._open();
  }

  _open() {
    const ws = new WebSocket(this.url);
    ws.binaryType = "arraybuffer";
    this.ws = ws;
    ws.onopen = () => {
      this.connected = true;
      this.onStatus(true);
      for (const [key, hz] of this.subscriptions) this._send(key, hz);
    };
    ws.onmessage = (event) => {
      this.received++;
      if (typeof event.data === "string") {
        const frame = JSON.parse(event.data);
        if (frame.type === "batch") for (const f of frame.frames) this.onFrame(f);
        else this.onFrame(frame);
      } else {
        this.onFrame(splitBinary(event.data));
      }
    };
    ws.onclose = () => {
      this.connected = false;
      this.onStatus(false);
      setTimeout(() => this._open(), 1000);
    };
  }

  _send(key, hz) {
    const [robot, topic] = key.split("|");
    if (this.connected) this.ws.send(JSON.stringify({ op: "subscribe", robot, topic, max_hz: hz }));
  }

  /** Subscribes once per (robot, topic); a later, faster request raises the rate (0 = unthinned). */
  subscribe(robot, topic, maxHz = 0) {
    const key = `${robot}|${topic}`;
    const old = this.subscriptions.get(key);
    const hz = old === undefined ? maxHz : (old === 0 || maxHz === 0 ? 0 : Math.max(old, maxHz));
    if (old === hz) return;
    this.subscriptions.set(key, hz);
    this._send(key, hz);
  }
}

/** uint32 big-endian N | N bytes JSON meta | payload (see server/protocol.py). */
export function splitBinary(buffer) {
  const n = new DataView(buffer).getUint32(0, false);
  const meta = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, n)));
  meta.blob = new Blob([new Uint8Array(buffer, 4 + n)], { type: `image/${meta.format || "jpeg"}` });
  return meta;
}
