"""The page while the recorder or the dashboard dies (chromium, real processes): the recordings panel says the recorder
does not answer and, once it is back, that it left a gap; the dashboard's spare takes over and the page reconnects
by itself."""

from __future__ import annotations

import os
import secrets
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from robot_nodes.runtime import BusConfig
from server.recording.service import RECORDER_TOKEN_ENV
from tests.dashboard_server import dashboard_server
from tests.running_recorder import answers, recorder_processes
from tests.support import REPO, free_port
from tests.teststand import TestStand
from tests.waiting import wait_for


@pytest.mark.browser
@pytest.mark.realtime
@pytest.mark.timeout(300)
def test_the_page_says_when_the_recorder_is_down_and_reconnects_after_a_dashboard_crash(
        router_endpoint: str, bus: BusConfig, tmp_path: Path, browser: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    token = secrets.token_urlsafe(12)
    monkeypatch.setenv(RECORDER_TOKEN_ENV, token)
    control_port, http_port = free_port(), free_port()
    common = ["--connect", router_endpoint, "--no-telemetry", "--recordings", str(tmp_path / "rec"), "--no-foxglove"]
    dashboard_args = [*common, "--recorder", f"http://127.0.0.1:{control_port}", "--standby-lock",
                      str(tmp_path / "dashboard.lock")]
    node = TestStand("r1", bus, overrides={"rate_hz": 50.0}).start()
    spare = None
    try:
        with recorder_processes([*common, "--control-port", str(control_port)], tmp_path) as (recorder,), \
                dashboard_server(dashboard_args, tmp_path, port=http_port) as dash:
            wait_for(lambda: answers(control_port, token), timeout=60, interval=0.1, what="the recorder up")
            with (tmp_path / "spare.log").open("wb") as out:
                spare = subprocess.Popen([sys.executable, "-m", "server", "--host", "127.0.0.1", "--port",
                                          str(http_port), *dashboard_args], cwd=REPO, stdout=out,
                                         stderr=subprocess.STDOUT,
                                         env=dict(os.environ, PITCHSIDE_TOKEN=dash.token, PYTHONUNBUFFERED="1"))
            assert dash.http.post(f"{dash.url}/api/recordings/start", json={"name": "page"}).is_success
            page = browser.new_page()
            page.goto(dash.page_url("all"))
            status = page.locator("#link-status")
            wait_for(lambda: status.text_content() == "connected", timeout=60, interval=0.1, what="page connected")
            panel = page.locator(".rec-status").first  # where the banners go
            recorder.send_signal(signal.SIGKILL)
            recorder.wait(10)
            wait_for(lambda: "does not answer" in (panel.text_content() or ""), timeout=30,
                     interval=0.2, what="the page saying the recorder is down")
            with recorder_processes([*common, "--control-port", str(control_port)], tmp_path):
                wait_for(lambda: "was restarted" in (panel.text_content() or ""), timeout=60,
                         interval=0.2, what="the page saying the recorder left a gap")
                # the dashboard dies: its spare serves, and the page reconnects by itself
                wait_for(lambda: "waits as its spare" in (tmp_path / "spare.log").read_text(), timeout=90,
                         interval=0.2, what="the spare ready")
                os.kill(dash.process.pid, signal.SIGKILL)
                wait_for(lambda: status.text_content() == "disconnected", timeout=30, interval=0.05,
                         what="the page seeing the dashboard gone")
                wait_for(lambda: status.text_content() == "connected", timeout=60, interval=0.1,
                         what="the page reconnected to the spare")
                assert spare.poll() is None
            page.close()
    finally:
        node.shutdown()
        if spare is not None:
            spare.terminate()
            spare.wait(10)
