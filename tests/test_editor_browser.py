"""The animation editor in chromium, clicked through: keyframe ghosts in 3D, edits, mirror, invert, undo/redo,
warnings. Real server (subprocess), real animation node on Zenoh, real viser; nothing is mocked."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from robot_nodes.animation.node import AnimationNode
from robot_nodes.runtime import BusConfig
from tests.conftest import free_port
from tests.dashboard_server import RunningServer, dashboard_server
from tests.waiting import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.browser]
CHROMIUM = Path("/usr/bin/chromium")
TIMEOUT_MS = 30_000
EDITOR = '[data-panel="animation"]'
ROBOT = "e1"
WAVE = {"name": "wave", "author": "test", "keyframes": [
    {"name": "up", "duration": 0.5, "goals": {"LShoulderPitch": 40.0, "LShoulderRoll": 20.0, "HeadPan": 10.0}},
    {"name": "out", "duration": 0.6, "pause": 0.1, "goals": {"LShoulderRoll": 60.0, "LElbow": -30.0}},
    {"name": "down", "duration": 0.8, "goals": {"LShoulderPitch": 0.0, "LShoulderRoll": 0.0, "LElbow": 0.0,
                                                "HeadPan": 0.0}}]}


@pytest.fixture
def browser() -> Iterator[Any]:
    if not CHROMIUM.exists():
        pytest.fail(f"{CHROMIUM} is missing: install Debian's chromium; the browser tests never download a browser")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        launched = pw.chromium.launch(executable_path=str(CHROMIUM), args=[
            "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update"])
        yield launched
        launched.close()


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    """The animation node's folder, with the test's animation in it."""
    out = tmp_path / "animations"
    out.mkdir()
    (out / "wave.json").write_text(json.dumps(WAVE))
    return out


@pytest.fixture
def animation_node(bus: BusConfig, folder: Path) -> Iterator[AnimationNode]:
    node = AnimationNode(ROBOT, bus, overrides={"animation_dir": str(folder)}).start()
    yield node
    node.shutdown()


@pytest.fixture
def server(router_endpoint: str, tmp_path: Path, animation_node: AnimationNode) -> Iterator[RunningServer]:
    args = ["--connect", router_endpoint, "--no-telemetry", "--robot3d", "--robot3d-port", str(free_port())]
    with dashboard_server(args, tmp_path) as running:
        yield running


def editor_page(browser: Any, server: RunningServer) -> Any:
    """The dashboard with the animation editor alone, focused on the test's robot, and the wave file opened."""
    page = browser.new_page(viewport={"width": 1400, "height": 2000})
    page.errors = []
    page.on("pageerror", lambda exc: page.errors.append(str(exc)))
    page.goto(server.url)
    page.evaluate(f"localStorage.clear(); localStorage.setItem('pitchside.focus', '{ROBOT}'); "
                  "localStorage.setItem('pitchside.layout', JSON.stringify({columns: 1, panels: ["
                  "{id: 'animation', w: 1, h: 8}]}))")
    page.reload()
    page.wait_for_selector(f'{EDITOR} [data-role="files"] option[value="wave"]', state="attached", timeout=TIMEOUT_MS)
    page.select_option(f'{EDITOR} [data-role="files"]', "wave")
    page.click(f'{EDITOR} button[data-act="open"]')
    page.wait_for_function("window.pitchside.animEditor.anim?.keyframes.length === 3", timeout=TIMEOUT_MS)
    return page


def keyframes(page: Any) -> list[dict[str, Any]]:
    """The editor's keyframes as it holds them (what save would write)."""
    return list(page.evaluate("window.pitchside.animEditor.anim.keyframes"))


def ghosts(server: RunningServer) -> dict[str, Any]:
    return dict(httpx.get(f"{server.url}/api/robots/{ROBOT}/animation-ghosts", timeout=20).json())


def wait_ghosts(server: RunningServer, want: list[int], selected: int, goals: list[dict[str, float]],
                what: str) -> dict[str, Any]:
    """Until the scene holds ghosts of exactly the keyframes ``want``, each posed at its keyframe's goals."""
    seen: dict[str, Any] = {}

    def right() -> bool:
        seen.clear()
        seen.update(ghosts(server))
        shown = seen["ghosts"]
        if [g["keyframe"] for g in shown] != want or len(seen["scene_nodes"]) != len(want):
            return False
        if [g["selected"] for g in shown] != [k == selected for k in want]:
            return False
        return all(abs(g["joints"][j] - v) < 0.01 for g in shown for j, v in goals[g["keyframe"]].items())

    try:
        wait_for(right, 30.0, 0.2, what)
    except AssertionError as exc:
        raise AssertionError(f"{exc}; the scene has {seen}") from None
    return seen


def test_keyframe_ghosts_follow_the_editor(browser: Any, server: RunningServer) -> None:
    page = editor_page(browser, server)
    goals = [kf["goals"] for kf in WAVE["keyframes"]]
    assert ghosts(server)["ghosts"] == []  # off until asked for
    page.select_option(f'{EDITOR} [data-role="ghosts"]', "all")
    wait_ghosts(server, [0, 1, 2], 0, goals, "a ghost per keyframe, the first selected")

    # select keyframe 2: it is drawn stronger; "selected ±1" shows it and its neighbour only
    page.click(f'{EDITOR} tr[data-kf="2"] td:first-child')
    wait_ghosts(server, [0, 1, 2], 2, goals, "keyframe 2 selected")
    page.select_option(f'{EDITOR} [data-role="ghosts"]', "near")
    wait_ghosts(server, [1, 2], 2, goals, "keyframe 2 and its neighbour")

    # an edit in the keyframe's goal table moves its ghost
    goal = page.locator(f'{EDITOR} [data-role="detail"] tr[data-joint="LElbow"] input[data-goal]')
    goal.fill("-70")
    goal.press("Tab")
    wait_ghosts(server, [1, 2], 2, [goals[0], goals[1], {**goals[2], "LElbow": -70.0}], "the edited goal")

    # off: the ghosts leave the scene; on again, then the page goes away: they leave too
    page.select_option(f'{EDITOR} [data-role="ghosts"]', "off")
    wait_for(lambda: ghosts(server)["scene_nodes"] == [], 20.0, 0.2, "no ghosts after off")
    page.select_option(f'{EDITOR} [data-role="ghosts"]', "all")
    wait_for(lambda: len(ghosts(server)["scene_nodes"]) == 3, 20.0, 0.2, "ghosts again")
    # closing the editor panel removes them
    page.click(f'{EDITOR} header button[data-act="hide"]')
    wait_for(lambda: ghosts(server)["scene_nodes"] == [], 20.0, 0.2, "no ghosts after the editor closed")
    assert not page.errors, page.errors

    # another page: ghosts on, then the page is closed
    page = editor_page(browser, server)
    page.select_option(f'{EDITOR} [data-role="ghosts"]', "all")
    wait_for(lambda: len(ghosts(server)["scene_nodes"]) == 3, 20.0, 0.2, "ghosts on the second page")
    page.close(run_before_unload=True)
    wait_for(lambda: ghosts(server)["scene_nodes"] == [], 20.0, 0.2, "no ghosts after the page closed")
