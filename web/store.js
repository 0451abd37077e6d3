// What the page knows: latest message per (robot, topic), the robots list with link health, the focused robot.

import { KEYS, getText, setText } from "./settings.js";

/** A stream that arrived at least this often (Hz) is periodic: once it stops, that is news. */
export const PERIODIC_HZ = 0.9;
/** Frames kept during a pause (events and the newest of each periodic stream); beyond, they are skipped. */
const HELD_MAX = 50000;

export class Store {
  /** eventTopics: topics published only when something happens (an animation plays, the robot walks or talks, a
   * teammate is heard...), from the topic table: silence on them is normal, their age is never stale or lost. */
  constructor(eventTopics = new Set()) {
    this.eventTopics = eventTopics;
    this.latest = new Map();   // robot -> Map(topic -> frame)
    this.arrivals = new Map(); // "robot|topic" and "robot" -> performance.now() of the last frame
    this.robots = [];          // RobotInfo list of the last "robots" frame
    this.robotsAt = 0;         // performance.now() when it arrived
    this.focus = getText(KEYS.focus);
    this.listeners = new Map(); // event -> Set(fn)
    this.matchMode = false;
    this.periodic = new Set(); // "robot|topic" of streams seen arriving at PERIODIC_HZ or more
    this.replayed = new Set(); // robots of the open replay (the server says so): shown apart, marked REPLAY
    this.replayListed = new Set(); // the replayed robots of the last "robots" frame
    this.paused = false;       // the live view frozen (space): frames keep arriving into `held`, shown on resume
    this.pausedAt = 0;
    this.held = [];            // frames that arrived while paused, in order
    this.heldAt = new Map();   // "robot|topic" of a periodic stream (or "robots") -> its index in held
    this.heldDropped = 0;
    this.hidden = new Set();   // robots the user hid in the views (show/hide per robot)
  }

  /** Shows or hides a robot in the views that draw robots (the field view); "shown" tells them. */
  setShown(robot, shown) {
    if (shown === !this.hidden.has(robot)) return;
    if (shown) this.hidden.delete(robot); else this.hidden.add(robot);
    this.emit("shown", robot);
  }

  /** The robot whose game state the page shows: during a replay the log's (the focused robot if it is replayed),
   * else the focused robot's, else any robot's; undefined when no robot has one. */
  gameSource() {
    const ids = [this.focus, ...this.robotIds()].filter((id) => this.get(id, "gamestate")?.data);
    return ids.find((id) => this.isReplayed(id)) ?? ids[0];
  }

  /** Freezes what the panels show; the connection stays subscribed and every frame is kept for resume(). */
  pause() {
    if (this.paused) return;
    this.paused = true;
    this.pausedAt = performance.now();
    this.emit("paused", true);
  }

  /** Shows what arrived meanwhile (the newest of each periodic stream, every event) and goes live again. */
  resume() {
    if (!this.paused) return;
    this.paused = false;
    const held = this.held;
    this.held = [];
    this.heldAt.clear();
    this.heldDropped = 0;
    for (const frame of held) this.handle(frame);
    this.emit("paused", false);
  }

  /** While paused: a periodic stream keeps only its newest frame (it replaces its own older one), events all. */
  _hold(frame) {
    const key = frame.type === "robots" ? "robots" : `${frame.robot}|${frame.topic}`;
    const coalesce = frame.type === "robots" || (this.periodic.has(key) && !this.eventTopics.has(frame.topic));
    if (coalesce && this.heldAt.has(key)) { this.held[this.heldAt.get(key)] = frame; return; }
    if (this.held.length >= HELD_MAX) { this.heldDropped++; return; } // a very long pause: the rest is skipped
    if (coalesce) this.heldAt.set(key, this.held.length);
    this.held.push(frame);
  }

  /** The page's clock for ages: stands still while paused, so nothing turns stale on screen meanwhile. */
  now() {
    return this.paused ? this.pausedAt : performance.now();
  }

  on(event, fn) {
    if (!this.listeners.has(event)) this.listeners.set(event, new Set());
    this.listeners.get(event).add(fn);
    return () => this.listeners.get(event).delete(fn);
  }

  emit(event, value) {
    for (const fn of this.listeners.get(event) || []) {
      try { fn(value); } catch (err) { console.error(`listener of ${event}`, err); }
    }
  }

  handle(frame) {
    if (this.paused && (frame.type === "msg" || frame.type === "image" || frame.type === "robots")) {
      this._hold(frame);
      return;
    }
    if (frame.type === "msg" || frame.type === "image") {
      if (!this.latest.has(frame.robot)) this.latest.set(frame.robot, new Map());
      this.latest.get(frame.robot).set(frame.topic, frame);
      const now = performance.now();
      this.arrivals.set(`${frame.robot}|${frame.topic}`, now);
      this.arrivals.set(frame.robot, now);
      if (frame.source === "replay") this.replayed.add(frame.robot);
      this.emit(`topic:${frame.topic}`, frame);
      if (!this.focus) this.setFocus(frame.robot);
    } else if (frame.type === "robots") {
      this.robots = frame.robots;
      this.robotsAt = performance.now();
      this.forgetClosedReplay(frame.robots);
      for (const info of frame.robots) {
        for (const [topic, s] of Object.entries(info.streams)) {
          if (s.rate_hz >= PERIODIC_HZ) this.periodic.add(`${info.robot}|${topic}`);
        }
      }
      this.emit("robots", frame.robots);
      if (!this.focus && frame.robots.length) this.setFocus(frame.robots[0].robot);
    } else if (frame.type === "hello") {
      this.matchMode = frame.match_mode;
      this.emit("hello", frame);
    } else if (frame.type === "error") {
      console.warn("server:", frame.error);
    }
  }

  get(robot, topic) {
    return this.latest.get(robot)?.get(topic);
  }

  /** Seconds since the server last heard from the robot (or stream), advanced locally between "robots" frames;
   * a frame this page received itself is fresher evidence. */
  robotAge(info, topic = null) {
    const now = this.now();
    const serverAge = (topic ? info.streams[topic].age_s : info.age_s) + (now - this.robotsAt) / 1000;
    const seen = this.arrivals.get(topic ? `${info.robot}|${topic}` : info.robot);
    return seen === undefined ? serverAge : Math.min(serverAge, (now - seen) / 1000);
  }

  /** Link health of one stream: "ok", "stale", "lost", or "event" for a stream whose silence means nothing
   * (an event topic, or one never seen arriving periodically). The robot's own status uses robotAge(info). */
  streamHealth(info, topic, staleAfter, lostAfter) {
    if (this.eventTopics.has(topic) || !this.periodic.has(`${info.robot}|${topic}`)) return "event";
    const age = this.robotAge(info, topic);
    return age >= lostAfter ? "lost" : age >= staleAfter ? "stale" : "ok";
  }

  /** True for a robot of the open replay (never a live one; the server names it apart, "replay.<id>"). */
  isReplayed(robot) {
    return this.replayed.has(robot);
  }

  /** The page's id of the replayed robot the log calls `logRobot` (messages name robots as the log does). */
  replayedId(logRobot) {
    return this.robots.find((r) => r.replayed && r.log_robot === logRobot)?.robot;
  }

  /** A replayed robot the server no longer lists left with its log (replay closed): the page forgets it too. */
  forgetClosedReplay(robots) {
    const listed = new Set(robots.filter((r) => r.replayed).map((r) => r.robot));
    for (const robot of this.replayListed) { // listed before: a frame in flight cannot race this
      if (listed.has(robot)) continue;
      this.replayed.delete(robot);
      this.latest.delete(robot);
      this.hidden.delete(robot);
      if (this.focus === robot) this.setFocus(robots.find((r) => !r.replayed)?.robot ?? "");
    }
    for (const robot of listed) this.replayed.add(robot);
    this.replayListed = listed;
  }

  robotIds() {
    const ids = new Set(this.robots.map((r) => r.robot));
    for (const id of this.latest.keys()) ids.add(id);
    return [...ids].sort();
  }

  setFocus(robot) {
    if (robot === this.focus) return;
    this.focus = robot;
    setText(KEYS.focus, robot);
    this.emit("focus", robot);
  }
}
