// A real Foxglove WebSocket client (@foxglove/ws-protocol over `ws`) that the pitchside tests and bench drive.
//
//   node client.mjs probe URL [--topic T]... [--seconds S] [--min N]
//       lists the channels with their schemas, subscribes to the topics given (every channel if none), decodes
//       each message with @foxglove/rosmsg2-serialization and prints one JSON object: channels, per topic the
//       count, decode errors and the last message decoded (and its bytes when small); channels in another
//       encoding (protobuf) are not decoded: their schema and bytes are printed for the test to decode.
//   node client.mjs list URL [--seconds S]
//       the channels the server advertises within S seconds (default 1), without subscribing.
//   node client.mjs stall URL
//       subscribes to every channel and then never reads again (its TCP window fills): a client that hangs.
//       Prints {"stalled": n} once subscribed, then waits until killed.
//   node client.mjs latency URL --seconds S [--clients N] [--latency-of SUFFIX]
//       N connections (default 1) subscribe to everything; prints messages/s per client (all, and of the hub's
//       streams alone, without derived channels such as the annotations) and the delay from the
//       log time (the hub message's stamp) to arrival, p50/p99 in ms, of the channels ending in SUFFIX
//       (default /joint_states, whose stamps the bench sets when it sends).
import wsProtocol from "@foxglove/ws-protocol";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;
const SUBPROTOCOL = "foxglove.sdk.v1";

function options(argv) {
  const out = { topics: [], seconds: 5, min: 1, clients: 1, latencyOf: "/joint_states" };
  for (let i = 0; i < argv.length; i++) {
    if (argv[i] === "--topic") out.topics.push(argv[++i]);
    else if (argv[i] === "--seconds") out.seconds = Number(argv[++i]);
    else if (argv[i] === "--min") out.min = Number(argv[++i]);
    else if (argv[i] === "--clients") out.clients = Number(argv[++i]);
    else if (argv[i] === "--latency-of") out.latencyOf = argv[++i];
    else throw new Error(`unknown option ${argv[i]}`);
  }
  return out;
}

// what JSON can carry of a decoded message: bigints as numbers, byte arrays as their length and first bytes
function plain(value) {
  if (typeof value === "bigint") return Number(value);
  if (value instanceof Uint8Array) return { bytes: value.length, head: Array.from(value.slice(0, 4)) };
  if (ArrayBuffer.isView(value)) return Array.from(value).map(plain);
  if (Array.isArray(value)) return value.map(plain);
  if (value && typeof value === "object") {
    return Object.fromEntries(Object.entries(value).map(([k, v]) => [k, plain(v)]));
  }
  return value;
}

function connect(url) {
  const ws = new WebSocket(url, [SUBPROTOCOL], { maxPayload: 256 * 1024 * 1024 });
  const client = new FoxgloveClient({ ws });
  return { ws, client };
}

function print(obj) {
  process.stdout.write(JSON.stringify(obj) + "\n");
}

async function probe(url, opts) {
  const { ws, client } = connect(url);
  const channels = new Map(); // id -> channel
  const readers = new Map(); // subscription id -> {topic, reader}
  const seen = {}; // topic -> {count, errors, last}
  const wanted = (topic) => opts.topics.length === 0 || opts.topics.includes(topic);
  const done = () => opts.topics.length > 0 &&
    opts.topics.every((t) => seen[t] && seen[t].count >= opts.min);
  let serverInfo = null;
  const finish = () => {
    print({
      subprotocol: ws.protocol, serverInfo,
      channels: [...channels.values()].map((c) => ({
        id: c.id, topic: c.topic, encoding: c.encoding, schemaName: c.schemaName, schemaEncoding: c.schemaEncoding,
        schemaBytes: c.schema.length,
      })),
      topics: seen,
    });
    client.close();
    process.exit(0);
  };
  client.on("serverInfo", (info) => { serverInfo = { name: info.name, capabilities: info.capabilities }; });
  client.on("advertise", (list) => {
    for (const channel of list) {
      channels.set(channel.id, channel);
      if (!wanted(channel.topic)) continue;
      const entry = (seen[channel.topic] ??= { count: 0, errors: [], last: null, schemaName: channel.schemaName });
      try {
        // ros2msg/cdr channels are decoded here; others (Foxglove's own protobuf schemas) come as bytes
        const reader = channel.encoding === "cdr" ? new MessageReader(parse(channel.schema, { ros2: true })) : null;
        if (!reader) entry.schema = channel.schema;
        readers.set(client.subscribe(channel.id), { topic: channel.topic, reader });
      } catch (err) {
        entry.errors.push(`schema: ${err.message}`);
      }
    }
  });
  client.on("unadvertise", (ids) => { for (const id of ids) channels.delete(id); });
  client.on("message", ({ subscriptionId, data }) => {
    const sub = readers.get(subscriptionId);
    if (!sub) return;
    const entry = seen[sub.topic];
    try {
      entry.last = sub.reader ? plain(sub.reader.readMessage(data)) : null;
      entry.count++;
      // the bytes as they came, for small messages: the tests compare them with what the robot sent
      entry.lastBytes = data.byteLength <= 4096 ? Buffer.from(data.buffer, data.byteOffset, data.byteLength)
        .toString("base64") : null;
    } catch (err) {
      entry.errors.push(err.message);
    }
    if (done()) finish();
  });
  client.on("error", (err) => { print({ error: String(err) }); process.exit(2); });
  client.on("close", () => finish());
  setTimeout(finish, opts.seconds * 1000);
}

async function stall(url) {
  const { ws, client } = connect(url);
  let subscribed = 0;
  client.on("advertise", (list) => {
    for (const channel of list) { client.subscribe(channel.id); subscribed++; }
    // wait for the subscriptions to leave, then stop reading: the kernel's buffers fill, then the server's queue
    setTimeout(() => { ws._socket.pause(); print({ stalled: subscribed }); }, 500);
  });
  client.on("error", () => {});
  setInterval(() => {}, 1 << 30);
}

function nowNs() {
  return (performance.timeOrigin + performance.now()) * 1e6; // the wall clock, as the hub's stamps
}

async function latency(url, opts) {
  const delays = [];
  const counts = [];
  const streamCounts = [];
  const WARMUP_MS = 1000;
  let first = 0;
  let start = 0;
  for (let i = 0; i < opts.clients; i++) {
    const { client } = connect(url);
    const timed = new Set(); // subscription ids whose delay is measured
    const streams = new Set(); // subscription ids of hub streams (cdr), not derived channels (annotations)
    counts.push(0);
    streamCounts.push(0);
    client.on("advertise", (list) => {
      for (const channel of list) {
        const id = client.subscribe(channel.id);
        if (channel.topic.endsWith(opts.latencyOf)) timed.add(id);
        if (channel.encoding === "cdr") streams.add(id);
      }
    });
    client.on("message", ({ subscriptionId, timestamp }) => {
      const now = performance.now();
      if (!first) first = now;
      if (now < first + WARMUP_MS) return; // the latest message of every channel comes at once on subscribe
      if (!start) start = now;
      counts[i]++;
      if (streams.has(subscriptionId)) streamCounts[i]++;
      if (timed.has(subscriptionId)) delays.push((nowNs() - Number(timestamp)) / 1e6);
    });
    client.on("error", (err) => { print({ error: String(err) }); process.exit(2); });
  }
  setTimeout(() => {
    const seconds = (performance.now() - start) / 1000;
    delays.sort((a, b) => a - b);
    const at = (q) => (delays.length ? delays[Math.min(delays.length - 1, Math.floor(q * delays.length))] : null);
    print({ clients: opts.clients, seconds, msgs_per_s: counts.map((c) => c / seconds),
            stream_msgs_per_s: streamCounts.map((c) => c / seconds), timed: delays.length,
            p50_ms: at(0.5), p99_ms: at(0.99) });
    process.exit(0);
  }, opts.seconds * 1000);
}

async function list(url, opts) {
  const { client } = connect(url);
  const channels = new Map();
  client.on("advertise", (added) => { for (const c of added) channels.set(c.id, c); });
  client.on("unadvertise", (ids) => { for (const id of ids) channels.delete(id); });
  client.on("error", (err) => { print({ error: String(err) }); process.exit(2); });
  setTimeout(() => {
    print({ channels: [...channels.values()].map((c) => ({ id: c.id, topic: c.topic, schemaName: c.schemaName })) });
    process.exit(0);
  }, opts.seconds * 1000);
}

const [mode, url, ...rest] = process.argv.slice(2);
const opts = options(rest);
if (mode === "probe") await probe(url, opts);
else if (mode === "stall") await stall(url);
else if (mode === "latency") await latency(url, opts);
else if (mode === "list") await list(url, { ...opts, seconds: rest.includes("--seconds") ? opts.seconds : 1 });
else { console.error("usage: node client.mjs probe|list|stall|latency URL [options]"); process.exit(64); }
