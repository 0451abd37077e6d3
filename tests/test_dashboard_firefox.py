"""`pitchside demo` in Debian's firefox-esr, driven over WebDriver BiDi (tests/firefox_bidi.py): the dashboard's
ES modules load without a console error and the panels show the live simulated robot, as in chromium
(tests/test_demo_browser.py). Screenshots go to test-output/firefox/ for review."""

from __future__ import annotations

import contextlib
import json
from collections.abc import Iterator
from pathlib import Path

import pytest

import schemas
from tests.conftest import REPO
from tests.firefox_bidi import FIREFOX, FirefoxBidi
from tests.running_demo import DashboardObserver, RunningDemo, running_demo
from tests.waiting import wait_for

OUTPUT = REPO / "test-output" / "firefox"
ROBOT = "robot1"
HCM_NAMES = {v: k for k, v in schemas.constants("humanoid_league_msgs/msg/RobotControlState").items()}
DATA_PANELS = ("team", "field", "relative", "hcm", "camera", "diagnostics")
LAB_PANELS = ("parameters", "animation", "teleop", "replay", "recordings")  # rendered, no console error
WEBGL_VIEWS = ("robot3d", "plots")  # iframes of their own servers; the chromium demo test covers them
pytestmark = [pytest.mark.slow, pytest.mark.browser, pytest.mark.timeout(300),
              pytest.mark.skipif(not FIREFOX.exists(), reason=f"{FIREFOX} is missing (apt-get install firefox-esr; "
                                                                  "`./run test` installs it)")]

# Pixels of the canvas drawn in the focused robot's colour (#ff2d95), and distinct colours of the camera image.
PINK_PIXELS = """(() => { const c = document.querySelector('section[data-panel="field"] canvas');
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data; let n = 0;
    for (let i = 0; i < d.length; i += 4) if (d[i] > 200 && d[i + 1] < 110 && d[i + 2] > 100 && d[i + 2] < 210) n++;
    return n; })()"""
CAMERA_COLOURS = """(() => { const c = document.querySelector('section[data-panel="camera"] canvas');
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data; const seen = new Set();
    for (let i = 0; i < d.length; i += 4 * 97) seen.add((d[i] << 16) | (d[i + 1] << 8) | d[i + 2]);
    return seen.size; })()"""


def _layout() -> dict[str, object]:
    """A saved layout: the WebGL views hidden, teleop shown; the page adds every other panel as by default."""
    return {"columns": 3, "panels": [{"id": "teleop", "w": 1, "h": 2, "hidden": False},
                                     *({"id": view, "w": 1, "h": 1, "hidden": True} for view in WEBGL_VIEWS)]}


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RunningDemo]:
    with running_demo(tmp_path_factory.mktemp("demo")) as running:
        yield running


@pytest.fixture
def firefox(demo: RunningDemo) -> Iterator[FirefoxBidi]:
    with FirefoxBidi.launch(width=1600, height=2000) as ff:
        # the layout is set in the dashboard's origin before the dashboard first loads (on a plain file of it):
        # the data panels only, the WebGL views (iframes of viser and rerun) hidden; headless firefox-esr here
        # has no WebGL at all, and the chromium demo test covers those views
        ff.navigate(f"{demo.url}/style.css")
        ff.evaluate(f"""(() => {{ localStorage.clear(); localStorage.setItem('pitchside.focus', '{ROBOT}');
            localStorage.setItem('pitchside.layout', JSON.stringify({json.dumps(_layout())})); }})()""")
        ff.navigate(demo.url)
        ff.wait_for_js("window.pitchside?.layout", 60, what="the dashboard's modules")
        hidden = ff.evaluate("window.pitchside.layout.state.panels.filter((p) => p.hidden).map((p) => p.id)")
        assert set(WEBGL_VIEWS) <= set(hidden), hidden
        try:
            yield ff
        finally:
            with contextlib.suppress(Exception):  # evidence only: the test's own failure is what counts
                ff.screenshot(OUTPUT / "last.png", full_page=True)


def test_dashboard_shows_the_live_demo_in_firefox(demo: RunningDemo, firefox: FirefoxBidi) -> None:
    ff = firefox
    timeout = 60.0
    with DashboardObserver(demo.ws_url, ("robot_state",)) as observer:
        # the modules loaded: every data panel is on the page and none failed
        ff.wait_for_js(f"document.querySelector('.card[data-robot=\"{ROBOT}\"]')", timeout, what="robot1's card")
        shown = set(ff.evaluate("[...document.querySelectorAll('section.panel')].map((e) => e.dataset.panel)"))
        assert shown >= set(DATA_PANELS) | set(LAB_PANELS), shown
        assert "panel failed" not in ff.evaluate("document.getElementById('grid').textContent")
        assert ff.evaluate("navigator.userAgent").find("Firefox/") > 0

        # team overview card and HCM graph: the state the robot's HCM last published
        def hcm() -> tuple[str, str, str] | None:
            state = observer.get(ROBOT, "robot_state")
            if state is None:
                return None
            card, current = ff.evaluate(f"""[document.querySelector('.card[data-robot="{ROBOT}"] .hcm-state')
                ?.textContent, document.querySelector('.hcm-node.current')?.dataset.state]""")
            return HCM_NAMES[state["data"]["state"]], card or "", current or ""

        wait_for(lambda: (s := hcm()) is not None and s[0] == s[1] == s[2], timeout, 0.2,
                 f"HCM state on the card and in the graph = robot_state ({hcm()})")
        assert ff.evaluate(f"document.querySelector('.card[data-robot=\"{ROBOT}\"]').dataset.status") == "ok"

        # field view: the robot drawn (its pixels on the canvas, in the focused robot's colour), still animating
        ff.wait_for_js(f"window.pitchside.fieldView.drawn.some((r) => r.id === '{ROBOT}')", timeout,
                       what="robot1 in the field view")
        ff.wait_for_js(f"{PINK_PIXELS} > 100", timeout, what="the focused robot's pixels on the field canvas")
        frames = ff.evaluate("window.pitchside.fieldView.frames")
        ff.wait_for_js(f"window.pitchside.fieldView.frames > {frames} + 10", 20, what="the field view animating")
        assert ff.evaluate("window.pitchside.fieldView.balls") >= 1

        # camera: JPEGs decoded and drawn (a picture, not a blank canvas)
        ff.wait_for_js("(c => c && c.images > 2 && c.width > 0)(window.pitchside.camera)", timeout,
                       what="camera images decoded")
        ff.wait_for_js(f"{CAMERA_COLOURS} > 20", timeout, what="the camera image on its canvas")

        # relative view and diagnostics get their data too
        ff.wait_for_js("window.pitchside.relativeView?.ball", timeout, what="the ball in the relative view")
        ff.wait_for_js("document.querySelectorAll('section[data-panel=\"diagnostics\"] tbody tr').length >= 5",
                       timeout, what="diagnostics rows")

        ff.evaluate("1")  # reads the events that arrived meanwhile
        assert not ff.console_errors, ff.console_errors
        assert not observer.error, observer.error

    ff.screenshot(OUTPUT / "dashboard.png")
    ff.screenshot(OUTPUT / "dashboard_full.png", full_page=True)
    for panel in DATA_PANELS:
        png = ff.screenshot(OUTPUT / f"{panel}.png", clip=ff.box(f'section[data-panel="{panel}"]'))
        assert png.startswith(b"\x89PNG") and len(png) > 1000, panel
    assert Path(OUTPUT / "field.png").stat().st_size > 1000
