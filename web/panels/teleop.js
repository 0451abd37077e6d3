// Teleop (lab only): keyboard (WASD/arrows, Q/E sideways) and an on-screen joystick drive the chosen robot through
// cmd_vel; the command is refreshed while held and the server sends zero when refreshes stop. Plus animation and
// penalize buttons.

import { expose } from "../test_hooks.js";
import { api, labToolOff, robotPath, robotPicker } from "../lab_api.js";
import { esc, statusLine } from "../dom.js";

const REFRESH_MS = 150;
const HOLD_S = 0.5;
const KEYS = {
  w: ["x", 1], arrowup: ["x", 1], s: ["x", -1], arrowdown: ["x", -1],
  a: ["yaw", 1], arrowleft: ["yaw", 1], d: ["yaw", -1], arrowright: ["yaw", -1],
  q: ["y", 1], e: ["y", -1],
};

export default {
  id: "teleop",
  title: "Teleop",
  size: [1, 2],
  hidden: true,
  create(body, ctx) {
    if (labToolOff(body, ctx.config)) return {};
    body.innerHTML = `<div class="lab-bar"><label>robot <select data-role="robot"></select></label>
        <label>speed <input type="range" data-role="speed" min="0.05" max="0.5" step="0.05" value="0.2"></label></div>
      <div class="teleop">
        <div class="joystick" tabindex="0" data-role="pad" title="drag, or click here and use WASD / arrows, Q/E sideways">
          <div class="knob" data-role="knob"></div></div>
        <div class="teleop-side">
          <div data-role="command" class="mono">x 0.00 y 0.00 yaw 0.00</div>
          <button data-act="halt" class="stop">■ stop</button>
          <div class="lab-bar"><input data-role="anim" list="teleop-anims" placeholder="animation" size="10">
            <datalist id="teleop-anims"></datalist><button data-act="play">play</button></div>
          <div class="lab-bar"><button data-act="penalize">penalize</button><button data-act="unpenalize">unpenalize</button></div>
          <div class="lab-status" data-role="status"></div>
        </div>
      </div>`;
    const $ = (sel) => body.querySelector(sel);
    const state = { robot: "", command: { x: 0, y: 0, yaw: 0 }, sent: 0, keys: new Set(), stick: null };
    expose("teleop", state);
    const status = statusLine($('[data-role="status"]'));
    const base = () => robotPath(state.robot);
    const picker = robotPicker($('[data-role="robot"]'), ctx, (robot) => {
      state.robot = robot;
      api("GET", `${base()}/animations`).then((list) => {
        $("#teleop-anims").innerHTML = list.animations.map((a) => `<option value="${esc(a.name ?? a.file)}">`).join("");
      }).catch(() => {});
    });

    function current() {
      const speed = Number($('[data-role="speed"]').value);
      const c = { x: 0, y: 0, yaw: 0 };
      for (const k of state.keys) { const [axis, sign] = KEYS[k]; c[axis] += sign * (axis === "yaw" ? speed * 3 : speed); }
      if (state.stick) { c.x += state.stick.x * speed; c.yaw += state.stick.yaw * speed * 3; }
      return c;
    }
    let active = false;
    async function tick() {
      const c = current();
      state.command = c;
      $('[data-role="command"]').textContent = `x ${c.x.toFixed(2)} y ${c.y.toFixed(2)} yaw ${c.yaw.toFixed(2)}`;
      const moving = c.x || c.y || c.yaw;
      try {
        if (moving) {
          await api("POST", `${base()}/teleop`, { ...c, hold_s: HOLD_S });
          state.sent++;
          active = true;
        } else if (active) {
          active = false;
          await api("POST", `${base()}/teleop/stop`);
        }
      } catch (err) { status(err.message, true); }
    }
    const timer = setInterval(tick, REFRESH_MS);

    const pad = $('[data-role="pad"]');
    pad.addEventListener("keydown", (e) => {
      const k = e.key.toLowerCase();
      if (KEYS[k]) { e.preventDefault(); state.keys.add(k); }
    });
    pad.addEventListener("keyup", (e) => { state.keys.delete(e.key.toLowerCase()); });
    pad.addEventListener("blur", () => state.keys.clear());
    const knob = $('[data-role="knob"]');
    function stickFrom(e) {
      const r = pad.getBoundingClientRect();
      const dx = Math.max(-1, Math.min(1, (e.clientX - r.left - r.width / 2) / (r.width / 2)));
      const dy = Math.max(-1, Math.min(1, (e.clientY - r.top - r.height / 2) / (r.height / 2)));
      state.stick = { x: -dy, yaw: -dx };
      knob.style.transform = `translate(${dx * r.width / 2}px, ${dy * r.height / 2}px)`;
    }
    pad.addEventListener("pointerdown", (e) => { pad.setPointerCapture(e.pointerId); pad.focus(); stickFrom(e); });
    pad.addEventListener("pointermove", (e) => { if (state.stick) stickFrom(e); });
    const release = () => { state.stick = null; knob.style.transform = ""; };
    pad.addEventListener("pointerup", release);
    pad.addEventListener("pointercancel", release);

    body.addEventListener("click", async (e) => {
      const act = e.target.dataset?.act;
      if (!act) return;
      try {
        if (act === "halt") { state.keys.clear(); release(); active = false; await api("POST", `${base()}/teleop/stop`); status("stopped"); }
        if (act === "play") {
          const name = $('[data-role="anim"]').value.trim();
          await api("POST", `${base()}/animation-play`, { animation: name });
          status(`playing ${name}`);
        }
        if (act === "penalize" || act === "unpenalize") {
          const r = await api("POST", `${base()}/penalize`, { penalize: act === "penalize" ? "on" : "off" });
          status(r.penalized ? "penalized" : "not penalized");
        }
      } catch (err) { status(err.message, true); }
    });
    return {
      destroy() {
        clearInterval(timer); picker.off();
        if (active) api("POST", `${base()}/teleop/stop`).catch(() => {});
      },
    };
  },
};
