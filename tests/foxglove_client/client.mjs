// A real Foxglove WebSocket client (@foxglove/ws-protocol over `ws`) that the pitchside tests and bench drive.
//
//   node client.mjs probe URL [--topic T]... [--seconds S] [--min N]
//       lists the channels with their schemas, subscribes to the topics given (every channel if none), decodes
//       each message with @foxglove/rosmsg2-serialization and prints one JSON object: channels, per topic the
//       count, decode errors and the last message decoded (and its bytes when small); channels in another
//       encoding (protobuf) are not decoded: their schema and bytes are printed for the test to decode.
//   node client.mjs hello URL [--seconds S] [--min N]
//       connects and prints what a user's app would see first: the subprotocol the server chose, its serverInfo
//       (name, capabilities) and the channels advertised (waits for at least N, default 0, at most S seconds), the
//       client's errors; or {refused: HTTP status, reason} when the server refused the handshake, or {error, code}
//       when the connection failed (a certificate not trusted).
//   every mode takes the connection options of a real app:
//       --subprotocol P (repeatable; default foxglove.sdk.v1): the subprotocols offered, as Lichtblick offers
//       foxglove.websocket.v1 (before its pull request #819) or both; --origin O: the Origin header a browser or
//       Electron sends (file:// for the desktop apps); --ca FILE: trust this CA for wss:// (else Node's own list).
//   node client.mjs list URL [--seconds S]
//       the channels the server advertises within S seconds (default 1), without subscribing.
//   node client.mjs stall URL
//       subscribes to every channel and then never reads again (its TCP window fills): a client that hangs.
//       Prints {"stalled": n} once subscribed, then waits until killed.
//   node client.mjs latency URL --seconds S [--clients N] [--latency-of SUFFIX]
//       N connections (default 1) subscribe to everything; prints messages/s per client (all, and of the hub's
//       streams alone, without the channels the server derives from them: the annotations, /tf, /tf_static, the
//       markers and the robot descriptions) and the delay from the
//       log time (the hub message's stamp) to arrival, p50/p99 in ms, of the channels ending in SUFFIX
//       (default /joint_states, whose stamps the bench sets when it sends).
//   node client.mjs session URL --script JSON [--seconds S]
//       runs the script's steps one after another, each waiting for its answer (at most S seconds, default 20), and
//       prints what came back and everything the server sent meanwhile: statuses, parameter values, the connection
//       graph, services, playback states and time (after each step a line {"progress": op}, so a test can act
//       between steps). Steps ({"op": ...}):
//         getParameters {names}, setParameters {parameters: [{name, value, type?}]} (noAnswer: true sends without
//         waiting for the values, for a server that refuses), subscribeParameterUpdates
//         {names}; callService {service, request} (encoded with the service's own ros2msg schema, CDR; the answer
//         decoded); fetchAsset {uri} (its size and SHA-256); subscribeGraph {}; waitGraphRemoved {topic} (a graph
//         update removes it); publish {topic, encoding ("cdr" or
//         "json"), schemaName, schema (ros2msg text, for cdr), message, hz, count, keep?} (advertises, sends count
//         messages, then unadvertises unless keep); subscribe {topic, count, until?} (decoded messages; until
//         {field: value}: also stops at a message with those values); waitChannel {topic}; waitService {service};
//         waitParameter {name, value} (a pushed parameterValues); wait {ms};
//         waitPlayback {status, didSeek?} (a playback state the server pushes by itself, after this step began);
//         playback {command: "play"|"pause", speed, seek?} (PlaybackControl: @foxglove/ws-protocol 0.8 has no call
//         for it, so its binary request is written here as the SDK's protocol defines it, and the server's
//         PlaybackState read back).
import crypto from "node:crypto";
import fs from "node:fs";
import wsProtocol from "@foxglove/ws-protocol";
import { parse } from "@foxglove/rosmsg";
import { MessageReader, MessageWriter } from "@foxglove/rosmsg2-serialization";
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;
const SUBPROTOCOL = "foxglove.sdk.v1";
const connection = { subprotocols: [], origin: undefined, ca: undefined }; // set from the options
// channels the server computes from the hub's streams (server/foxglove/scene.py, annotations.py)
const DERIVED = /\/(tf|tf_static|markers|robot_description|camera\/annotations)$/;

function options(argv) {
  const out = { topics: [], seconds: 5, min: 1, clients: 1, latencyOf: "/joint_states", script: "[]" };
  for (let i = 0; i < argv.length; i++) {
    if (argv[i] === "--topic") out.topics.push(argv[++i]);
    else if (argv[i] === "--subprotocol") connection.subprotocols.push(argv[++i]);
    else if (argv[i] === "--origin") connection.origin = argv[++i];
    else if (argv[i] === "--ca") connection.ca = fs.readFileSync(argv[++i]);
    else if (argv[i] === "--seconds") out.seconds = Number(argv[++i]);
    else if (argv[i] === "--min") out.min = Number(argv[++i]);
    else if (argv[i] === "--clients") out.clients = Number(argv[++i]);
    else if (argv[i] === "--latency-of") out.latencyOf = argv[++i];
    else if (argv[i] === "--script") out.script = argv[++i];
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
  const subprotocols = connection.subprotocols.length ? connection.subprotocols : [SUBPROTOCOL];
  const ws = new WebSocket(url, subprotocols, { maxPayload: 256 * 1024 * 1024, origin: connection.origin,
                                               ca: connection.ca });
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
      topics: seen, resubscribed: resubscribed.size,
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
  // foxglove-sdk 0.30 now and then answers a subscription to a channel it has just advertised with "Unknown channel
  // ID" (seen in about 1 of 10 runs on a loaded machine, its log showing the refusal before the advertisement):
  // such a subscription is asked for again, once, while the channel is still advertised, and counted
  const resubscribed = new Set(); // channel ids
  client.on("status", (status) => {
    const refused = /Unknown channel ID: (\d+)/.exec(status.message);
    const channel = refused && channels.get(Number(refused[1]));
    if (!channel || !wanted(channel.topic) || resubscribed.has(channel.id)) return;
    resubscribed.add(channel.id);
    const reader = [...readers.values()].find((r) => r.topic === channel.topic);
    setTimeout(() => { if (channels.has(channel.id)) readers.set(client.subscribe(channel.id), reader); }, 100);
  });
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
        if (channel.encoding === "cdr" && !DERIVED.test(channel.topic)) streams.add(id);
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

// -- session: a script of requests, each answered before the next ---------------------------------------------
const PLAYBACK_CONTROL_REQUEST = 3; // client binary opcode (foxglove-sdk's protocol)
const PLAYBACK_STATE = 5; // server binary opcode
const PLAYBACK_STATUS = ["playing", "paused", "buffering", "ended"];

function playbackRequest(command, speed, seek, requestId) {
  const id = Buffer.from(requestId, "utf8");
  const out = Buffer.alloc(1 + 1 + 4 + 1 + 8 + 4 + id.length);
  let at = out.writeUInt8(PLAYBACK_CONTROL_REQUEST, 0);
  at = out.writeUInt8(command === "play" ? 0 : 1, at);
  at = out.writeFloatLE(speed, at);
  at = out.writeUInt8(seek == null ? 0 : 1, at);
  at = out.writeBigUInt64LE(BigInt(seek ?? 0), at);
  at = out.writeUInt32LE(id.length, at);
  id.copy(out, at);
  return out;
}

function playbackState(data) {
  const buf = Buffer.from(data);
  if (buf.length < 19 || buf.readUInt8(0) !== PLAYBACK_STATE) return null;
  const idLength = buf.readUInt32LE(15);
  return { status: PLAYBACK_STATUS[buf.readUInt8(1)], currentTime: Number(buf.readBigUInt64LE(2)),
           speed: buf.readFloatLE(10), didSeek: buf.readUInt8(14) !== 0,
           requestId: buf.subarray(19, 19 + idLength).toString("utf8") };
}

async function session(url, opts) {
  const { ws, client } = connect(url);
  const out = { serverInfo: null, statuses: [], results: [], parameterValues: [], graph: [], services: [],
                playback: [], time: null, channels: [], errors: [] };
  const channels = new Map();
  const services = new Map(); // name -> service
  const waiters = []; // {test(event, payload), resolve}
  const emit = (event, payload) => {
    for (const waiter of [...waiters]) {
      if (waiter.test(event, payload)) { waiters.splice(waiters.indexOf(waiter), 1); waiter.resolve(payload); }
    }
  };
  const until = (test, what) => new Promise((resolve, reject) => {
    const waiter = { test, resolve };
    waiters.push(waiter);
    setTimeout(() => {
      const i = waiters.indexOf(waiter);
      if (i >= 0) { waiters.splice(i, 1); reject(new Error(`no answer: ${what}`)); }
    }, opts.seconds * 1000);
  });
  client.on("serverInfo", (info) => {
    out.serverInfo = { name: info.name, capabilities: info.capabilities, supportedEncodings: info.supportedEncodings,
                       dataStartTime: info.dataStartTime ?? null, dataEndTime: info.dataEndTime ?? null };
    emit("serverInfo", info);
  });
  client.on("status", (status) => { out.statuses.push({ level: status.level, message: status.message });
                                    emit("status", status); });
  client.on("advertise", (list) => { for (const c of list) channels.set(c.id, c); emit("advertise", list); });
  client.on("unadvertise", (ids) => { for (const id of ids) channels.delete(id); });
  client.on("advertiseServices", (list) => {
    for (const service of list) services.set(service.name, service);
    emit("advertiseServices", list);
  });
  client.on("unadvertiseServices", (ids) => {
    for (const [name, service] of services) if (ids.includes(service.id)) services.delete(name);
  });
  client.on("parameterValues", (msg) => { out.parameterValues.push(msg); emit("parameterValues", msg); });
  client.on("connectionGraphUpdate", (msg) => { out.graph.push(msg); emit("connectionGraphUpdate", msg); });
  client.on("serviceCallResponse", (msg) => emit("serviceCall", msg));
  client.on("serviceCallFailure", (msg) => emit("serviceCall", msg));
  client.on("fetchAssetResponse", (msg) => emit("fetchAsset", msg));
  client.on("time", (msg) => { out.time = Number(msg.timestamp); });
  const readers = new Map();
  client.on("message", (msg) => emit("message", msg));
  client.on("error", (err) => {
    // PlaybackState is the SDK's (foxglove.sdk.v1), not in @foxglove/ws-protocol 0.8: read below. A client of
    // foxglove.websocket.v1 must never get it
    const playback = String(err).includes(`binary message: ${PLAYBACK_STATE}`) && ws.protocol === SUBPROTOCOL;
    if (!playback) out.errors.push(String(err));
  });
  ws.on("message", (data, isBinary) => {
    if (!isBinary) return;
    const state = playbackState(data);
    if (state) { out.playback.push(state); emit("playback", state); }
  });
  const finish = (code) => {
    out.subprotocol = ws.protocol;
    out.channels = [...channels.values()].map((c) => c.topic).sort();
    out.services = [...services.keys()].sort();
    print(out);
    client.close();
    process.exit(code);
  };
  let nextId = 1;
  try {
    await until((event) => event === "serverInfo", "serverInfo");
    for (const step of JSON.parse(opts.script)) {
      const id = `step${nextId++}`;
      if (step.op === "wait") {
        await new Promise((resolve) => setTimeout(resolve, step.ms));
        out.results.push({ op: "wait" });
      } else if (step.op === "getParameters" || step.op === "setParameters") {
        const answer = step.noAnswer ? null : until((e, m) => e === "parameterValues" && m.id === id,
                                                    `${step.op} ${id}`);
        if (step.op === "getParameters") client.getParameters(step.names, id);
        else client.setParameters(step.parameters, id);
        out.results.push({ op: step.op, parameters: answer ? (await answer).parameters : null });
      } else if (step.op === "subscribeParameterUpdates") {
        client.subscribeParameterUpdates(step.names);
        out.results.push({ op: step.op });
      } else if (step.op === "waitParameter") {
        const has = (m) => m.parameters.some((p) => p.name === step.name && p.value === step.value);
        const seen = out.parameterValues.some(has) ? null : until((e, m) => e === "parameterValues" && has(m),
                                                                   `parameter ${step.name}`);
        if (seen) await seen;
        out.results.push({ op: step.op });
      } else if (step.op === "waitService") {
        if (!services.has(step.service)) {
          await until(() => services.has(step.service), `service ${step.service}`);
        }
        out.results.push({ op: step.op, service: services.get(step.service) });
      } else if (step.op === "waitChannel") {
        const has = () => [...channels.values()].some((c) => c.topic === step.topic);
        if (!has()) await until(() => has(), `channel ${step.topic}`);
        out.results.push({ op: step.op });
      } else if (step.op === "callService") {
        const service = services.get(step.service);
        if (!service) throw new Error(`no service ${step.service}`);
        const writer = new MessageWriter(parse(service.request.schema, { ros2: true }));
        const callId = nextId++;
        const answer = until((e, m) => e === "serviceCall" && m.callId === callId, `call ${step.service}`);
        client.sendServiceCallRequest({ serviceId: service.id, callId, encoding: service.request.encoding,
                                        data: writer.writeMessage(step.request) });
        const reply = await answer;
        if (reply.op === "serviceCallFailure") {
          out.results.push({ op: step.op, failure: reply.message });
        } else {
          const reader = new MessageReader(parse(service.response.schema, { ros2: true }));
          out.results.push({ op: step.op, response: plain(reader.readMessage(reply.data)) });
        }
      } else if (step.op === "fetchAsset") {
        const requestId = nextId++;
        const answer = until((e, m) => e === "fetchAsset" && m.requestId === requestId, `asset ${step.uri}`);
        client.fetchAsset(step.uri, requestId);
        const reply = await answer;
        out.results.push(reply.status === 0
          ? { op: step.op, bytes: reply.data.byteLength, sha256: crypto.createHash("sha256")
              .update(Buffer.from(reply.data.buffer, reply.data.byteOffset, reply.data.byteLength)).digest("hex") }
          : { op: step.op, error: reply.error });
      } else if (step.op === "waitGraphRemoved") {
        const removed = (m) => (m.removedTopics ?? []).includes(step.topic);
        if (!out.graph.some(removed)) await until((e, m) => e === "connectionGraphUpdate" && removed(m),
                                                  `${step.topic} removed from the graph`);
        out.results.push({ op: step.op });
      } else if (step.op === "subscribeGraph") {
        const answer = until((e) => e === "connectionGraphUpdate", "the connection graph");
        client.subscribeConnectionGraph();
        await answer;
        out.results.push({ op: step.op });
      } else if (step.op === "publish") {
        const channelId = client.advertise({ topic: step.topic, encoding: step.encoding, schemaName: step.schemaName,
                                             ...(step.schema ? { schema: step.schema, schemaEncoding: "ros2msg" }
                                               : {}) });
        const writer = step.encoding === "cdr" ? new MessageWriter(parse(step.schema, { ros2: true })) : null;
        const data = writer ? writer.writeMessage(step.message) : new TextEncoder().encode(JSON.stringify(step.message));
        for (let i = 0; i < step.count; i++) {
          client.sendMessage(channelId, data);
          await new Promise((resolve) => setTimeout(resolve, 1000 / step.hz));
        }
        if (!step.keep) client.unadvertise(channelId);
        out.results.push({ op: step.op, sent: step.count });
      } else if (step.op === "subscribe") {
        const channel = [...channels.values()].find((c) => c.topic === step.topic);
        if (!channel) throw new Error(`no channel ${step.topic}`);
        const reader = new MessageReader(parse(channel.schema, { ros2: true }));
        const subscriptions = new Set([client.subscribe(channel.id)]);
        for (const id of subscriptions) readers.set(id, reader);
        const got = [];
        let resubscribed = false;
        await new Promise((resolve, reject) => {
          const waiter = { test: (e, m) => {
            // the SDK's refusal of a subscription to a channel it has just advertised (see the watch mode
            // above): asked for again, once
            const refused = e === "status" && /Unknown channel ID: (\d+)/.exec(m.message);
            if (refused && Number(refused[1]) === channel.id && !resubscribed) {
              resubscribed = true;
              setTimeout(() => {
                if (!channels.has(channel.id)) return;
                const again = client.subscribe(channel.id);
                readers.set(again, reader);
                subscriptions.add(again);
              }, 100);
            }
            if (e !== "message" || !subscriptions.has(m.subscriptionId)) return false;
            const message = plain(reader.readMessage(m.data));
            got.push({ timestamp: Number(m.timestamp), message });
            const matches = step.until && Object.entries(step.until).every(([field, value]) => message[field] === value);
            return got.length >= step.count || Boolean(matches);
          }, resolve };
          waiters.push(waiter);
          setTimeout(() => { const i = waiters.indexOf(waiter); if (i >= 0) { waiters.splice(i, 1); resolve(); } },
                     opts.seconds * 1000);
        });
        for (const id of subscriptions) client.unsubscribe(id);
        out.results.push({ op: step.op, topic: step.topic, messages: got, resubscribed });
      } else if (step.op === "waitPlayback") {
        const pushed = (m) => !m.requestId && m.status === step.status && (!step.didSeek || m.didSeek);
        const known = out.playback.length;
        await until((e, m) => e === "playback" && pushed(m) && out.playback.indexOf(m) >= known,
                    `a pushed playback state ${step.status}`);
        out.results.push({ op: step.op, state: out.playback[out.playback.length - 1] });
      } else if (step.op === "playback") {
        const answer = until((e, m) => e === "playback" && m.requestId === id, `playback ${step.command}`);
        ws.send(playbackRequest(step.command, step.speed ?? 1.0, step.seek ?? null, id));
        out.results.push({ op: step.op, state: await answer });
      } else {
        throw new Error(`unknown step ${step.op}`);
      }
      print({ progress: step.op }); // a test may act between steps (kill a node once the graph is known)
    }
  } catch (err) {
    out.errors.push(String(err));
    finish(0);
  }
  finish(0);
}

async function hello(url, opts) {
  const { ws, client } = connect(url);
  const channels = new Map();
  const errors = [];
  let serverInfo = null;
  const finish = () => {
    print({ subprotocol: ws.protocol, serverInfo, channels: [...channels.values()].map((c) => c.topic).sort(),
            errors });
    client.close();
    process.exit(0);
  };
  const ready = () => serverInfo && channels.size >= opts.min;
  ws.on("unexpected-response", (_request, response) => {
    let reason = "";
    response.on("data", (chunk) => { reason += chunk; });
    response.on("end", () => { print({ refused: response.statusCode, reason: reason.trim() }); process.exit(0); });
  });
  ws.on("error", (err) => { print({ error: String(err), code: err.code ?? null }); process.exit(0); });
  client.on("serverInfo", (info) => {
    serverInfo = { name: info.name, capabilities: info.capabilities, supportedEncodings: info.supportedEncodings };
    if (ready()) finish();
  });
  client.on("advertise", (list) => { for (const c of list) channels.set(c.id, c); if (ready()) finish(); });
  client.on("error", (err) => errors.push(String(err)));
  setTimeout(finish, opts.seconds * 1000);
}

const [mode, url, ...rest] = process.argv.slice(2);
const opts = options(rest);
if (mode === "probe") await probe(url, opts);
else if (mode === "stall") await stall(url);
else if (mode === "latency") await latency(url, opts);
else if (mode === "hello") await hello(url, { ...opts, min: rest.includes("--min") ? opts.min : 0 });
else if (mode === "list") await list(url, { ...opts, seconds: rest.includes("--seconds") ? opts.seconds : 1 });
else if (mode === "session") await session(url, { ...opts, seconds: rest.includes("--seconds") ? opts.seconds : 20 });
else {
  console.error("usage: node client.mjs probe|hello|list|stall|latency|session URL [options]");
  process.exit(64);
}
