"""Replay and recordings panels in Debian's chromium against a real server with a log opened (slow)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.dashboard_server import RunningServer, dashboard_server
from tests.test_browser_panels import OUTPUT
from tests.test_replay import _pitchside_log

pytestmark = [pytest.mark.slow, pytest.mark.browser]


@pytest.fixture
def replaying(tmp_path: Path) -> Iterator[RunningServer]:
    folder = tmp_path / "rec"
    folder.mkdir()
    _pitchside_log(folder / "game.mcap", seconds=20.0)
    with dashboard_server(["--no-live", "--no-telemetry", "--recordings", str(folder), "--replay",
                           str(folder / "game.mcap")], tmp_path) as server:
        yield server


def test_replay_and_recordings_panels(browser: Any, replaying: RunningServer) -> None:
    OUTPUT.mkdir(exist_ok=True)
    page = browser.new_page(bypass_csp=True, viewport={"width": 1600, "height": 2400})
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(replaying.login_url)
    page.evaluate("localStorage.clear()")
    page.reload()
    panel = page.locator(".replay")
    panel.locator(".replay-state", has_text="paused").wait_for(timeout=20_000)
    assert panel.locator('.replay-mark[data-name="goal own 1:0"]').count() == 1
    assert panel.locator(".replay-topics tbody tr").count() == 3  # r1, r2 joint_states; r1 gamestate
    panel.locator(".replay-plot-topic").select_option("r1|joint_states")
    panel.locator(".replay-speed").select_option("10")
    panel.locator(".replay-play").click()
    page.wait_for_function("document.querySelectorAll('.replay-plot-field option').length > 1", timeout=20_000)
    panel.locator(".replay-plot-field").select_option("position/0")
    page.wait_for_function("window.pitchside.store.robotIds().includes('r2')", timeout=20_000)
    panel.locator(".replay-state", has_text="ended").wait_for(timeout=30_000)
    assert panel.locator(".replay-time").inner_text() == "0:20.0 / 0:20.0"  # played to the end of 19.98 s
    panel.locator(".replay-timeline").click(position={"x": 5, "y": 5})  # seek near the start
    panel.locator(".replay-state", has_text="paused").wait_for(timeout=10_000)

    recordings = page.locator(".rec-controls").locator("..")
    recordings.locator(".rec-name").fill("browser")
    recordings.locator(".rec-start").click()
    recordings.locator(".rec-running").wait_for(timeout=10_000)
    recordings.locator(".rec-stop").click()
    recordings.locator('tr[data-file$="_browser.mcap"]').wait_for(timeout=10_000)
    assert recordings.locator('tr[data-file="game.mcap"]').inner_text().count("0:19") == 1
    page.screenshot(path=str(OUTPUT / "replay_panels.png"), full_page=True)
    assert not errors, errors
