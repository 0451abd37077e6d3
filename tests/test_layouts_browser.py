"""Layouts and keys in Debian's chromium at 1920x1080: presets one click each, a user's changes to a preset kept,
layouts exported and imported as JSON, the address carrying preset and focused robot; 1-9 focus a robot, F fills
the window with the panel under the mouse, space pauses the live view (data keeps arriving, shown on resume), ?
lists the shortcuts."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from tests.dashboard_server import RunningServer
from tests.teststand import SceneStand
from tests.waiting import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.browser]
MATCH = ["field", "team", "game", "links", "recordings"]
LAB = ["parameters", "animation", "robot3d", "hcm", "teleop", "plots", "node_log", "diagnostics"]
REPLAY = ["field", "hcm", "replay", "recordings", "team", "plots", "robot3d"]


def _panels(page: Any) -> list[str]:
    return page.eval_on_selector_all("#grid > .panel", "els => els.map(e => e.dataset.panel)")


def _query(page: Any) -> dict[str, str]:
    return page.evaluate("Object.fromEntries(new URLSearchParams(location.search))")


def test_presets_are_one_click_remembered_exported_and_linked(browser: Any, scene: RunningServer,
                                                              tmp_path: Path) -> None:
    page = browser.new_page(viewport={"width": 1920, "height": 1080}, accept_downloads=True)
    page.goto(scene.login_url)
    page.evaluate("localStorage.clear()")
    page.reload()
    page.wait_for_selector('#presets button[data-preset="lab"][aria-pressed="true"]')  # the lab's default
    assert _panels(page) == LAB
    for preset, panels in (("match", MATCH), ("replay", REPLAY), ("lab", LAB)):
        page.click(f'#presets button[data-preset="{preset}"]')
        assert _panels(page) == panels and _query(page)["preset"] == preset

    # a change to a preset is that preset's own: kept across presets and reloads, until reset
    page.click('[data-panel="diagnostics"] button[data-act="hide"]')
    page.click('[data-panel="parameters"] button[data-act="wider"]')
    page.click('#presets button[data-preset="match"]')
    assert _panels(page) == MATCH
    page.click('#presets button[data-preset="lab"]')
    assert _panels(page) == [p for p in LAB if p != "diagnostics"]
    page.reload()
    page.wait_for_selector('[data-panel="parameters"]')
    assert _panels(page) == [p for p in LAB if p != "diagnostics"]
    assert page.evaluate("window.pitchside.layout.state.panels.find(p => p.id === 'parameters').w") == 2

    # export, change, import: the file's arrangement comes back; a bad file changes nothing and says why
    with page.expect_download() as download:
        page.click("#layout-export")
    saved = json.loads(Path(download.value.path()).read_text())
    assert saved["format"] == "pitchside-layout" and saved["preset"] == "lab"
    page.click("#layout-reset")
    assert _panels(page) == LAB
    page.set_input_files("#layout-file", files=[{"name": "mine.json", "mimeType": "application/json",
                                                 "buffer": json.dumps(saved).encode()}])
    wait_for(lambda: _panels(page) == [p for p in LAB if p != "diagnostics"], 10.0, 0.1, "the imported layout")
    assert "imported from mine.json" in page.text_content("#layout-status")
    page.set_input_files("#layout-file", files=[{"name": "bad.json", "mimeType": "application/json",
                                                 "buffer": b'{"panels": 3}'}])
    wait_for(lambda: "bad.json" in (page.text_content("#layout-status") or ""), 10.0, 0.1, "the refusal")
    assert "not a pitchside layout" in page.text_content("#layout-status")
    assert _panels(page) == [p for p in LAB if p != "diagnostics"]

    # the address carries preset and focused robot: a link opens the same view in another browser
    page.select_option("#focus-select", "r2")
    page.click('#presets button[data-preset="replay"]')
    assert _query(page) == {"preset": "replay", "robot": "r2"}
    link = page.url
    other = browser.new_context(viewport={"width": 1920, "height": 1080}).new_page()  # nothing remembered there
    other.goto(link)
    other.wait_for_selector('#presets button[data-preset="replay"][aria-pressed="true"]')
    assert _panels(other) == REPLAY
    wait_for(lambda: other.evaluate("window.pitchside.store.focus") == "r2", 10.0, 0.1, "r2 focused")
    other.context.close()


def test_keys_focus_maximise_pause_and_help(browser: Any, scene: RunningServer,
                                            stands: dict[str, SceneStand]) -> None:
    page = browser.new_page(viewport={"width": 1920, "height": 1080})
    page.goto(scene.page_url("match"))
    page.evaluate("localStorage.clear()")
    page.reload()
    page.wait_for_selector('.card[data-robot="r2"]')
    page.mouse.move(5, 300)  # nowhere in particular; keys go to the page

    page.keyboard.press("2")
    wait_for(lambda: page.evaluate("window.pitchside.store.focus") == "r2", 5.0, 0.05, "2 focuses r2")
    assert page.input_value("#focus-select") == "r2" and _query(page)["robot"] == "r2"
    page.keyboard.press("1")
    wait_for(lambda: page.evaluate("window.pitchside.store.focus") == "r1", 5.0, 0.05, "1 focuses r1")

    # F: the panel under the mouse fills the window; F again (or Esc) puts it back
    box = page.locator('[data-panel="game"]').bounding_box()
    page.mouse.move(box["x"] + 40, box["y"] + 60)
    page.keyboard.press("f")
    big = page.locator('[data-panel="game"]').bounding_box()
    assert big["width"] > 1800 and big["height"] > 900, big
    assert page.locator(".panel.maximised").count() == 1
    page.keyboard.press("f")
    assert page.locator(".panel.maximised").count() == 0
    assert page.locator('[data-panel="game"]').bounding_box()["width"] < 600

    # space: the view holds still while data keeps arriving; on resume what arrived is shown
    def drawn_x() -> float:
        return float(page.evaluate("window.pitchside.fieldView.drawn.find(r => r.id === 'r1').x"))
    wait_for(lambda: drawn_x() == -2.0, 10.0, 0.1, "r1 drawn at x=-2")
    page.keyboard.press(" ")
    assert page.evaluate("window.pitchside.store.paused") is True
    stands["r1"].params.x = 1.0  # the robot moves on
    wait_for(lambda: page.evaluate("window.pitchside.store.held.length") > 5, 10.0, 0.1, "frames held")
    assert "PAUSED" in page.text_content("#pause-live")
    page.wait_for_timeout(600)  # a few frames of the field view: it still shows where r1 was
    assert drawn_x() == -2.0
    assert page.get_attribute('.card[data-robot="r1"]', "data-status") == "ok"  # a pause is no link loss
    page.keyboard.press(" ")
    wait_for(lambda: drawn_x() == 1.0, 10.0, 0.1, "r1 drawn where it went meanwhile")
    assert page.text_content("#pause-live") == "live"

    # ?: the shortcuts; Esc closes them
    page.keyboard.press("?")
    assert page.locator("dialog#shortcuts[open]").count() == 1
    assert "Space" in page.text_content("dialog#shortcuts") and "1 … 9" in page.text_content("dialog#shortcuts")
    page.keyboard.press("Escape")
    assert page.locator("dialog#shortcuts[open]").count() == 0
    # keys typed into a field are the field's
    page.click('[data-panel="recordings"] input')
    page.keyboard.press("2")
    assert page.evaluate("window.pitchside.store.focus") == "r1"
