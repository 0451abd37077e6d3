// The top bar's session: whether this browser may control (the server's HttpOnly cookie, which no script can
// read; /api/config says whether the page's requests carry it), signing in with the token, and the telemetry
// key the server uses, so a team sees before kick-off whether it is the development key.

import { api } from "./lab_api.js";

export class SessionBar {
  constructor(root, config) {
    this.root = root;
    this.config = config;
    this.render();
  }

  render() {
    const { config } = this;
    const key = document.createElement("span");
    const dev = config.telemetry_key === "development";
    key.className = `badge ${dev ? "warn" : "ok"}`;
    key.dataset.role = "telemetry-key";
    key.textContent = dev ? "telemetry: DEV KEY" : `telemetry key ${config.telemetry_key}`;
    key.title = dev ? "the published development key: anyone at the venue can forge or read this telemetry; "
      + "make a team key with `pitchside telemetry-key FILE`"
      : "fingerprint of the team's telemetry key; the robots' telemetry diagnostics show the same";
    const access = document.createElement("span");
    access.dataset.role = "access";
    access.className = `badge ${config.control ? "ok" : "warn"}`;
    access.textContent = config.control ? "control" : "view only";
    access.title = config.control ? "this browser may control (signed in with the server's token)"
      : "open the link the server printed at start-up, or sign in with its token, to control robots";
    const parts = [key, access];
    if (!config.control) parts.push(this.signInForm());
    this.root.replaceChildren(...parts);
  }

  signInForm() {
    const form = document.createElement("form");
    form.className = "sign-in";
    const input = document.createElement("input");
    input.type = "password";
    input.placeholder = "token";
    input.autocomplete = "off";
    input.size = 10;
    const button = document.createElement("button");
    button.type = "submit";
    button.textContent = "sign in";
    const error = document.createElement("span");
    error.className = "lab-status bad";
    form.append(input, button, error);
    form.addEventListener("submit", async (event) => {
      event.preventDefault();
      try {
        await api("POST", "api/session", { token: input.value });
        location.reload(); // every panel starts again, now with control
      } catch (err) {
        error.textContent = err.message;
      }
    });
    return form;
  }
}
