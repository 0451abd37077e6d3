// How a robot or ball moves on the field view between its samples: the newest sample, its velocity, and the pose
// shown, which follows the samples smoothly (web/panels/field_view.js draws it). Pure: no DOM.

export const MOTION = {
  horizonS: 0.15,  // extrapolate at most this far past the newest sample (and at most 1.5 sample intervals)
  smoothS: 0.06,   // a new sample's correction fades in with this time constant instead of a jump
  jumpM: 0.75,     // a correction bigger than this (teleport, replay seek) is shown at once
  maxSpeed: 4,     // m/s; faster apparent motion is noise or a jump, not velocity
  maxTurn: 8,      // rad/s
};

/** a - b wrapped into [-pi, pi], so turning through pi is not a jump. */
function angleDiff(a, b) {
  return Math.atan2(Math.sin(a - b), Math.cos(a - b));
}

/** One moving thing (a robot pose or a ball): its newest sample, velocity from the two newest, and the pose it is
 * shown at, which follows the samples smoothly. A stream that stops is shown where it was last seen (plus at most
 * one short extrapolation step), never carried on. */
export class Track {
  constructor() {
    this.key = null;   // the frame the newest sample came from
    this.p = null;     // newest sample {x, y, theta}
    this.stamp = 0;    // its time (s, the message's stamp)
    this.at = 0;       // performance.now() when it arrived
    this.interval = 0; // s between the two newest samples
    this.v = { x: 0, y: 0, theta: 0 };
    this.off = { x: 0, y: 0, theta: 0 }; // shown minus predicted: fades out
    this.shown = null;
    this.drawnAt = 0;
  }

  update(key, p, stamp, now) {
    if (key === this.key) return;
    this.key = key;
    const prev = this.p, dt = stamp - this.stamp;
    this.v = { x: 0, y: 0, theta: 0 };
    this.interval = 0;
    if (prev && dt > 0.005 && dt < 1) {
      this.interval = dt;
      this.v = { x: (p.x - prev.x) / dt, y: (p.y - prev.y) / dt, theta: angleDiff(p.theta, prev.theta) / dt };
      if (Math.hypot(this.v.x, this.v.y) > MOTION.maxSpeed || Math.abs(this.v.theta) > MOTION.maxTurn) {
        this.v = { x: 0, y: 0, theta: 0 };
      }
    }
    this.p = p;
    this.stamp = stamp;
    this.at = now;
    const s = this.shown;
    this.off = { x: 0, y: 0, theta: 0 };
    if (s) {
      const off = { x: s.x - p.x, y: s.y - p.y, theta: angleDiff(s.theta, p.theta) };
      if (Math.hypot(off.x, off.y) < MOTION.jumpM && Math.abs(off.theta) < 1) this.off = off;
    }
  }

  pose(now) {
    const horizon = Math.min(MOTION.horizonS, 1.5 * this.interval);
    const age = Math.max(0, Math.min((now - this.at) / 1000, horizon));
    const fade = Math.exp(-Math.max(0, now - (this.drawnAt || now)) / 1000 / MOTION.smoothS);
    this.drawnAt = now;
    for (const k of ["x", "y", "theta"]) {
      this.off[k] = Math.abs(this.off[k] * fade) < 1e-4 ? 0 : this.off[k] * fade;
    }
    const p = this.p, v = this.v, off = this.off;
    this.shown = { x: p.x + v.x * age + off.x, y: p.y + v.y * age + off.y, theta: p.theta + v.theta * age + off.theta };
    return { ...this.shown, confidence: p.confidence };
  }
}
