"""Script injection, in Debian's chromium with the page's own Content-Security-Policy in force: names and strings
from the bus (any process on it) and from a log file (another team's) carry markup, and the dashboard shows them
as text and runs none of it."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

import pytest
import zenoh

import schemas
from schemas.logs import LogWriter
from tests.dashboard_server import dashboard_server
from tests.waiting import wait_for
from wire.keys import topic_key

pytestmark = [pytest.mark.slow, pytest.mark.browser]
MARKUP = "<img src=x onerror=window.__pwned=1>"


def _hostile_log(path: Path) -> None:
    """Another team's log: a robot id, a topic and a bookmark with markup, next to a well-named stream."""
    with LogWriter(path) as writer:
        for k in range(20):
            t = 1_700_000_000_000_000_000 + k * 50_000_000
            state = schemas.make("humanoid_league_msgs/msg/RobotControlState", state=2)
            writer.write(MARKUP, "robot_state", state, log_time_ns=t)
            writer.write("r8", f"odd_{MARKUP}", state, log_time_ns=t)
            writer.write("r8", "robot_state", state, log_time_ns=t)
        writer.add_bookmark(MARKUP, log_time_ns=1_700_000_000_000_000_000 + 500_000_000)


def _publish_hostile(client: zenoh.Session, stop: threading.Event) -> None:
    """A process on the bus: a robot id with markup, and a well-named robot whose strings carry markup."""
    state = schemas.encode(schemas.make("humanoid_league_msgs/msg/RobotControlState", state=2))
    status = schemas.make("diagnostic_msgs/msg/DiagnosticStatus", level=2, name=MARKUP, message=MARKUP,
                          hardware_id=MARKUP, values=[schemas.make("diagnostic_msgs/msg/KeyValue", key=MARKUP,
                                                                   value=MARKUP)])
    diagnostics = schemas.encode(schemas.make("diagnostic_msgs/msg/DiagnosticArray", status=[status]))
    servo = schemas.encode(schemas.make(
        "humanoid_league_msgs/msg/AdditionalServoData",
        temperature=[schemas.make("sensor_msgs/msg/Temperature", temperature=71.0,
                                  header=schemas.make("std_msgs/msg/Header", frame_id=MARKUP))], voltage=[12.0]))
    while not stop.wait(0.1):
        client.put(topic_key(MARKUP, "robot_state"), state)
        client.put(topic_key("r9", "robot_state"), state)
        client.put(topic_key("r9", "diagnostics"), diagnostics)
        client.put(topic_key("r9", "servo_data"), servo)


def test_markup_from_the_bus_and_from_a_log_is_shown_as_text_and_never_runs(
        browser: Any, router_endpoint: str, client: zenoh.Session, tmp_path: Path) -> None:
    rec = tmp_path / "rec"
    rec.mkdir()
    _hostile_log(rec / "other_team.mcap")
    stop = threading.Event()
    publisher = threading.Thread(target=_publish_hostile, args=(client, stop), daemon=True)
    publisher.start()
    try:
        with dashboard_server(["--connect", router_endpoint, "--no-telemetry", "--recordings", str(rec)],
                              tmp_path) as server:
            page = browser.new_page(viewport={"width": 1600, "height": 2400})  # the page's CSP stays in force
            console: list[str] = []
            page.on("console", lambda m: console.append(m.text))
            page.on("pageerror", lambda exc: console.append(str(exc)))
            page.goto(server.page_url("all"))
            reply = server.http.post(f"{server.url}/api/replay/open", json={"path": "other_team.mcap"})
            assert reply.status_code == 200, reply.text
            wait_for(lambda: page.evaluate("document.querySelector('[data-panel=\"diagnostics\"]')?.textContent"
                                           ".includes('<img src=x')"), 30.0, 0.2, "the diagnostics row of r9")
            wait_for(lambda: MARKUP in (page.text_content('.card[data-robot="r9"]') or ""), 30.0, 0.2,
                     "robot r9's card with its hottest servo")
            assert page.evaluate("window.__pwned") is None
            assert page.evaluate("document.querySelectorAll('img[src=\"x\"]').length") == 0
            robots = page.evaluate("window.pitchside.store.robotIds()")
            assert "r9" in robots and not any("<" in r for r in robots), robots  # dropped where it entered
            options = page.evaluate("[...document.querySelectorAll('option')].map((o) => o.value)")
            assert not any("<" in o for o in options), options
            page.reload()
            wait_for(lambda: MARKUP in (page.text_content('[data-panel="replay"]') or ""), 30.0, 0.2,
                     "the log's names in the replay panel")
            assert page.evaluate("window.__pwned") is None
            assert page.evaluate("document.querySelectorAll('img[src=\"x\"]').length") == 0
            violations = [m for m in console if "Content Security Policy" in m]
            assert not violations, violations  # nothing of ours needed the policy to stop it
    finally:
        stop.set()
        publisher.join(5)


def test_a_page_opened_without_the_token_is_view_only_until_signed_in(browser: Any, tmp_path: Path) -> None:
    with dashboard_server(["--no-live", "--no-telemetry"], tmp_path) as server:
        page = browser.new_page(viewport={"width": 1600, "height": 2400})
        errors: list[str] = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        page.goto(server.url + "/")
        page.wait_for_selector('[data-role="access"]', timeout=30_000)
        assert page.text_content('[data-role="access"]') == "view only"
        assert "telemetry: DEV KEY" in (page.text_content('[data-role="telemetry-key"]') or "")
        assert "view only" in (page.text_content('[data-panel="parameters"]') or "")
        assert page.context.cookies() == []
        page.fill(".sign-in input", "wrong")
        page.click(".sign-in button")
        wait_for(lambda: "token" in (page.text_content(".sign-in .lab-status") or ""), 10.0, 0.1, "the refusal")
        page.fill(".sign-in input", server.token)
        page.click(".sign-in button")
        wait_for(lambda: page.locator('[data-role="access"]').count() and
                 page.text_content('[data-role="access"]') == "control", 30.0, 0.2, "signed in after reload")
        cookie = page.context.cookies()[0]
        assert cookie["httpOnly"] and cookie["sameSite"] == "Strict" and cookie["value"] != server.token
        assert page.evaluate("document.cookie") == ""  # no script of the page can read it
        assert not errors, errors
