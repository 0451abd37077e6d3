"""The README's pictures: the three layout presets of the running demo at 1920x1080, taken by this test into
docs/pictures/, so the README always shows today's dashboard. The test fails when a preset needs page scrolling
at 1920x1080 or one of its panels draws nothing. The Replay preset shows a replay of a recording the test makes."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from tests.pictures import drawn_share, picture
from tests.running_demo import RunningDemo, running_demo
from tests.state_graph_view import measure_state_graph
from tests.support import REPO, launch_chromium
from tests.waiting import wait_for

PICTURES = REPO / "docs" / "pictures"
ROBOT = "robot1"
PRESETS = {
    "match": ["field", "team", "game", "links", "recordings"],
    "lab": ["parameters", "animation", "robot3d", "teleop", "plots", "camera"],
    "replay": ["field", "hcm", "replay", "recordings", "plots", "robot3d"],
}
MIN_DRAWN = 0.004  # a panel body with less than this share of non-background pixels draws nothing
pytestmark = [pytest.mark.slow, pytest.mark.browser, pytest.mark.timeout(600)]


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RunningDemo]:
    with running_demo(tmp_path_factory.mktemp("pictures")) as running:
        yield running


@pytest.fixture
def page(demo: RunningDemo) -> Iterator[Any]:
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        browser = launch_chromium(pw)
        page = browser.new_page(viewport={"width": 1920, "height": 1080})  # the page's own CSP in force
        page.errors = []
        page.on("pageerror", lambda exc: page.errors.append(str(exc)))
        page.set_default_timeout(60_000)
        page.goto(demo.page_url("match"))
        page.evaluate("localStorage.clear()")
        try:
            yield page
        finally:
            browser.close()


def _record(demo: RunningDemo, seconds: float) -> str:
    """A recording of the demo (its name in the recordings folder), made through the server's API."""
    http = httpx.Client(base_url=demo.url, headers=demo.auth, timeout=30.0)
    started = http.post("/api/recordings/start", json={"name": "pictures"})
    assert started.status_code == 200, started.text
    time.sleep(seconds)  # the length of the recording itself, not a wait for a condition
    stopped = http.post("/api/recordings/stop")
    assert stopped.status_code == 200, stopped.text
    return Path(stopped.json()["path"]).name


def _layout_problems(page: Any, panels: list[str]) -> list[str]:
    """Page scrolling, panels outside the window or under the playback bar."""
    found: list[str] = page.evaluate("""(panels) => {
        const problems = [], doc = document.documentElement;
        if (doc.scrollHeight > innerHeight || doc.scrollWidth > innerWidth)
          problems.push(`the page scrolls: ${doc.scrollWidth}x${doc.scrollHeight} in ${innerWidth}x${innerHeight}`);
        const bar = document.querySelector('.playback-bar:not([hidden])')?.getBoundingClientRect();
        for (const id of panels) {
          const r = document.querySelector(`section[data-panel="${id}"]`).getBoundingClientRect();
          if (r.left < 0 || r.top < 0 || r.right > innerWidth || r.bottom > innerHeight) problems.push(`${id} cut off`);
          if (bar && bar.height && r.bottom > bar.top) problems.push(`${id} under the playback bar`);
        }
        return problems; }""", panels)
    return found


def _silent_panels(page: Any, panels: list[str]) -> dict[str, float]:
    """Panels whose body draws (almost) nothing: one picture of the whole page, cut at each body's box (a screenshot
    per panel makes Chromium draw every WebGL view again each time, seconds apiece here)."""
    boxes: dict[str, list[float]] = page.evaluate("""(panels) => Object.fromEntries(panels.map((id) => {
        const r = document.querySelector(`section[data-panel="${id}"] > .panel-body`).getBoundingClientRect();
        return [id, [r.left, r.top, r.right, r.bottom]]; }))""", panels)
    whole = picture(page.screenshot(animations="disabled"))
    shares = {panel: drawn_share(whole.crop(tuple(round(v) for v in box))) for panel, box in boxes.items()}
    return {panel: share for panel, share in shares.items() if share < MIN_DRAWN}


def test_each_preset_fits_1920x1080_draws_every_panel_and_is_pictured(demo: RunningDemo, page: Any) -> None:
    PICTURES.mkdir(parents=True, exist_ok=True)
    name = _record(demo, 8.0)
    http = httpx.Client(base_url=demo.url, headers=demo.auth, timeout=60.0)
    for preset, panels in PRESETS.items():
        if preset == "replay":  # a replay open and playing: the playback bar, the replayed robot beside the live one
            assert http.post("/api/replay/open", json={"path": name}).status_code == 200
            assert http.post("/api/replay/play").status_code == 200
        page.goto(f"{demo.url}/?preset={preset}&robot={ROBOT}")
        page.wait_for_selector(f'#presets button[data-preset="{preset}"][aria-pressed="true"]')
        shown = page.eval_on_selector_all("#grid > .panel", "els => els.map(e => e.dataset.panel)")
        assert shown == panels, (preset, shown)
        if preset == "replay":
            page.wait_for_selector(".playback-bar:not([hidden])")
            wait_for(lambda: page.locator(".hcm-node.current").count() == 1, 60.0, 0.5, "the HCM graph drawn")
            graph = measure_state_graph(page)
            assert graph["states"] >= 17 and graph["problems"] == [], graph
        if preset == "match":
            page.wait_for_selector(f'.card[data-robot="{ROBOT}"]')
        if preset == "replay":  # halfway through, held there: the picture shows a replay in progress
            http.post("/api/replay/pause")
            assert http.post("/api/replay/seek", json={"t_s": 4.0}).status_code == 200
        page.mouse.move(1919, 1079)  # no hover marks in the picture
        assert _layout_problems(page, panels) == [], preset
        # the 3D robot and the plots (software WebGL here) come in last: every panel draws something in time
        wait_for(lambda shown=panels: not _silent_panels(page, shown), 120.0, 2.0,
                 f"every panel of {preset} drawing ({_silent_panels(page, panels)} drew nothing)")
        page.screenshot(path=str(PICTURES / f"{preset}.png"))
        assert _layout_problems(page, panels) == [], preset
    assert not page.errors, page.errors
