"""`pitchside demo` in Debian's firefox-esr, driven over WebDriver BiDi (tests/firefox_bidi.py): the dashboard's
ES modules load without a console error and every panel shows the live simulated robot, as in chromium
(tests/test_demo_browser.py). The 3D robot (viser) and the plots (rerun's web viewer) draw with WebGL, which
firefox-esr has only in a real window: firefox runs on a virtual X display (Xvfb) when there is one, else headless
and those two views are skipped. Screenshots go to test-output/firefox/ for review."""

from __future__ import annotations

import contextlib
import json
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

import schemas
from tests import firefox_bidi
from tests.firefox_bidi import FIREFOX, FirefoxBidi, LogEntry
from tests.pictures import picture, wait_for_moving_plot
from tests.running_demo import DashboardObserver, RunningDemo, running_demo
from tests.support import REPO
from tests.waiting import wait_for

OUTPUT = REPO / "test-output" / "firefox"
ROBOT = "robot1"
HCM_NAMES = schemas.constant_names("humanoid_league_msgs/msg/RobotControlState")
DATA_PANELS = ("team", "field", "relative", "hcm", "camera", "diagnostics")
LAB_PANELS = ("parameters", "animation", "teleop", "replay", "recordings")  # rendered, no console error
WEBGL_VIEWS = ("robot3d", "plots")  # iframes of their own servers (viser, rerun), drawn with WebGL
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


# The largest canvas of a frame: its WebGL version (null: no WebGL context) and what it shows, copied onto a 2D
# canvas: dark pixels (viser's robot is dark grey over a light grid and a transparent sky). Only for a canvas whose
# owner has made its context: getContext on a fresh canvas would make it, with default attributes, for the owner.
WEBGL_CANVAS = """(() => { const c = [...document.querySelectorAll('canvas')]
        .sort((a, b) => b.width * b.height - a.width * a.height)[0];
    if (!c || !c.width || !c.height) return null;
    const gl = c.getContext('webgl2') || c.getContext('webgl');
    const copy = document.createElement('canvas'); copy.width = c.width; copy.height = c.height;
    const g = copy.getContext('2d'); g.drawImage(c, 0, 0); const d = g.getImageData(0, 0, c.width, c.height).data;
    let dark = 0; for (let i = 0; i < d.length; i += 4) if (d[i + 3] > 200 && d[i] + d[i + 1] + d[i + 2] < 330) dark++;
    return { webgl: gl ? (gl instanceof WebGL2RenderingContext ? 2 : 1) : null, width: c.width, height: c.height,
             dark, renderer: gl?.getParameter(gl.RENDERER) }; })()"""
WEBGL_RENDERER = """(() => { const gl = document.createElement('canvas').getContext('webgl2');
    return gl && gl.getParameter(gl.RENDERER); })()"""
# a blocked request to a host other than this machine, as firefox reports it
OUTSIDE = re.compile(r"https?://(?!127\.0\.0\.1[:/]|localhost[:/])[^/\s]+")
CSP_BLOCK = "Content-Security-Policy: The page\u2019s settings blocked the loading of a resource"  # as Firefox words it


def _layout(webgl: bool) -> dict[str, object]:
    """A saved layout: with WebGL its views first (in sight from the start, wherever the other panels' content
    puts them), without it hidden; teleop shown; the page adds every other panel."""
    views = [{"id": "plots", "w": 3, "h": 2, "hidden": False}, {"id": "robot3d", "w": 1, "h": 2, "hidden": False}]
    return {"columns": 3, "panels": [*(views if webgl else []), {"id": "teleop", "w": 1, "h": 2, "hidden": False},
                                     *({"id": view, "w": 1, "h": 1, "hidden": True}
                                       for view in WEBGL_VIEWS if not webgl)]}


def _local(url: str) -> bool:
    return OUTSIDE.match(url) is None


def _frames(ff: FirefoxBidi, sources: dict[str, str]) -> dict[str, str] | None:
    """The browsing context of each panel's iframe (by its URL), once all have one."""
    found = {panel: next((c for c, url in ff.frames().items() if url.startswith(src)), "")
             for panel, src in sources.items()}
    return found if all(found.values()) else None


def _unexpected_errors(ff: FirefoxBidi) -> list[LogEntry]:
    """Console errors and uncaught exceptions, less one kind: rerun's web viewer calls home (usage analytics,
    its latest release, its examples); the server's Content-Security-Policy makes Firefox refuse each such
    request before it leaves (logged as a CSP block, and by the viewer as a failed fetch). Requests to this
    machine must all succeed (asserted on their own)."""
    blocked = [m.group(0) for entry in ff.console_errors
               if CSP_BLOCK in entry.text and (m := OUTSIDE.search(entry.text))]
    errors = []
    for entry in ff.console_errors:
        if CSP_BLOCK in entry.text and OUTSIDE.search(entry.text):
            continue
        if blocked and entry.text.startswith("TypeError: NetworkError when attempting to fetch resource") and \
                "/re_viewer.js" in entry.source:
            continue
        errors.append(entry)
    return errors


def _check_no_errors(ff: FirefoxBidi) -> None:
    ff.evaluate("1")  # reads the events that arrived meanwhile
    local = [(url, error) for url, error in ff.failed_requests if _local(url) and error != "NS_BINDING_ABORTED"]
    assert not local, local
    errors = _unexpected_errors(ff)
    assert not errors, errors


def _scroll_to(ff: FirefoxBidi, panel: str) -> None:
    """Brings a panel into the viewport: firefox does not draw an iframe out of sight, and where the panels land
    depends on their content."""
    ff.evaluate(f"document.querySelector('section[data-panel=\"{panel}\"]').scrollIntoView({{block: 'center'}})")


def _picture(ff: FirefoxBidi, panel: str, path: Path) -> Any:
    """A screenshot of a panel (written to ``path``) as a PIL image."""
    return picture(ff.screenshot(path, clip=ff.box(f'section[data-panel="{panel}"]')))


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RunningDemo]:
    with running_demo(tmp_path_factory.mktemp("demo")) as running:
        yield running


@pytest.fixture(scope="module")
def display() -> Iterator[str | None]:
    """An X display for firefox (Xvfb), or None: headless, without WebGL."""
    if not firefox_bidi.XVFB.exists():
        print(f"\n{firefox_bidi.XVFB} is missing (apt-get install xvfb): firefox-esr runs headless, without WebGL, "
              "and the 3D robot and the plots are not checked in firefox")
        yield None
        return
    with firefox_bidi.virtual_display() as number:
        yield number


@pytest.fixture(scope="module")
def firefox(demo: RunningDemo, display: str | None) -> Iterator[FirefoxBidi]:
    webgl = display is not None
    with FirefoxBidi.launch(width=1600, height=2000, display=display) as ff:
        # the layout is set in the dashboard's origin before the dashboard first loads (on a plain file of it):
        # without WebGL (headless firefox-esr) the WebGL views (iframes of viser and rerun) are hidden
        ff.navigate(f"{demo.url}/style.css")
        ff.evaluate(f"""(() => {{ localStorage.clear(); localStorage.setItem('pitchside.focus', '{ROBOT}');
            localStorage.setItem('pitchside.layout', JSON.stringify({json.dumps(_layout(webgl))})); }})()""")
        ff.navigate(demo.page_url("all"))
        ff.wait_for_js("window.pitchside?.layout", 60, what="the dashboard's modules")
        hidden = ff.evaluate("window.pitchside.layout.state.panels.filter((p) => p.hidden).map((p) => p.id)")
        assert (set(WEBGL_VIEWS) & set(hidden)) == (set() if webgl else set(WEBGL_VIEWS)), hidden
        try:
            yield ff
        finally:
            with contextlib.suppress(Exception):  # evidence only: the test's own failure is what counts
                ff.screenshot(OUTPUT / "last.png", full_page=True)
                (OUTPUT / "console.txt").write_text("".join(
                    f"{e.kind} {e.level}: {e.text}\n    {e.source[:300]}\n" for e in ff.log if e.level != "debug") +
                    "".join(f"debug: {e.text[:200]}\n" for e in [e for e in ff.log if e.level == "debug"][-30:]) +
                    "".join(f"failed request: {url} {error}\n" for url, error in ff.failed_requests))


def test_dashboard_shows_the_live_demo_in_firefox(demo: RunningDemo, display: str | None,
                                                   firefox: FirefoxBidi) -> None:
    ff = firefox
    timeout = 60.0
    with DashboardObserver(demo.ws_url, ("robot_state",)) as observer:
        # the modules loaded: every data panel is on the page and none failed
        ff.wait_for_js(f"document.querySelector('.card[data-robot=\"{ROBOT}\"]')", timeout, what="robot1's card")
        shown = set(ff.evaluate("[...document.querySelectorAll('section.panel')].map((e) => e.dataset.panel)"))
        assert shown >= set(DATA_PANELS) | set(LAB_PANELS) | (set(WEBGL_VIEWS) if display else set()), shown
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

        _check_no_errors(ff)
        assert not observer.error, observer.error

    ff.screenshot(OUTPUT / "dashboard.png")
    ff.screenshot(OUTPUT / "dashboard_full.png", full_page=True)
    for panel in DATA_PANELS:
        png = ff.screenshot(OUTPUT / f"{panel}.png", clip=ff.box(f'section[data-panel="{panel}"]'))
        assert png.startswith(b"\x89PNG") and len(png) > 1000, panel
    assert Path(OUTPUT / "field.png").stat().st_size > 1000


def test_3d_robot_and_plots_in_firefox(demo: RunningDemo, display: str | None, firefox: FirefoxBidi) -> None:
    """viser's client draws the robot and rerun's viewer the plots, with WebGL 2 in software (Mesa llvmpipe)."""
    if display is None:
        pytest.skip(f"{firefox_bidi.XVFB} is missing (apt-get install xvfb): headless firefox-esr has no WebGL")
    ff = firefox
    timeout = 90.0
    renderer = ff.evaluate(WEBGL_RENDERER)
    assert renderer, "no WebGL 2 in firefox-esr on the virtual display"
    sources = {panel: ff.wait_for_js(f"document.querySelector('section[data-panel=\"{panel}\"] iframe')?.src",
                                     30, what=f"the {panel} iframe") for panel in WEBGL_VIEWS}
    frames = wait_for(lambda: _frames(ff, sources), timeout, 0.5, f"the iframes {sources} loaded")
    assert frames is not None  # wait_for returns only a truthy value

    # 3D robot: the server drives it with joint_states; viser's WebGL canvas shows it (its dark grey meshes)
    _scroll_to(ff, "robot3d")
    wait_for(lambda: httpx.get(f"{demo.url}/api/robot3d", timeout=5).json()["robots"].get(ROBOT), timeout, 0.5,
             "robot1 in the 3D view")
    # (three.js marks the canvas whose context it made: only then is it safe to ask for the context, see below)
    ff.wait_for_js("document.querySelector('canvas[data-engine]')", timeout, 0.5, "viser's three.js canvas",
                   frame=frames["robot3d"])
    robot3d = ff.wait_for_js(f"(s => s && s.dark > 1000 && s)({WEBGL_CANVAS})", timeout, 0.5,
                             "the robot drawn on viser's canvas", frame=frames["robot3d"])
    assert robot3d["webgl"] == 2, robot3d

    # plots: rerun's viewer draws the lines of the data the server logs (coloured pixels), and keeps drawing new
    # data. Its canvas is in the page before its 43 MB of wasm have loaded: asking that canvas for a WebGL context
    # before the viewer does would create the context with the browser's default attributes, and the viewer
    # (wgpu) would then draw into it and never show a frame in firefox. So the context is looked at only after the
    # viewer has drawn.
    _scroll_to(ff, "plots")
    wait_for(lambda: httpx.get(f"{demo.url}/api/plots", timeout=5).json()["logged"] > 50, timeout, 0.5, "plots fed")
    wait_for_moving_plot(lambda: _picture(ff, "plots", OUTPUT / "plots.png"), timeout)
    plots = ff.evaluate(WEBGL_CANVAS, frame=frames["plots"])
    assert plots["webgl"] == 2 and plots["width"] > 300, plots

    _picture(ff, "robot3d", OUTPUT / "robot3d.png")
    ff.screenshot(OUTPUT / "dashboard_webgl.png", full_page=True)
    _check_no_errors(ff)
    refused = sorted({m.group(0) for e in ff.console_errors if CSP_BLOCK in e.text and (m := OUTSIDE.search(e.text))})
    print(f"\nWebGL renderer: {renderer}; robot3d canvas {robot3d}; plots canvas {plots}, drawn; "
          f"rerun's viewer asked other hosts (refused by the server's CSP before leaving): {refused}; "
          f"requests to other hosts that failed: {ff.failed_requests and [u for u, _ in ff.failed_requests]}")
