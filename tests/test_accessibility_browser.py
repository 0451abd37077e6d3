"""WCAG AA in Debian's chromium: every layout preset in the light (high contrast) and the dark theme, judged by
axe-core with the page's own Content-Security-Policy in force; zero serious or critical violations. The state
graph's SVG names, which axe does not judge, are measured against their boxes (AA: 4.5:1)."""

from __future__ import annotations

import json
from typing import Any

import pytest

from tests.accessibility import serious_violations, svg_state_contrast
from tests.dashboard_server import RunningServer
from tests.support import REPO
from tests.waiting import wait_for

OUTPUT = REPO / "test-output" / "accessibility"
pytestmark = [pytest.mark.slow, pytest.mark.browser]


@pytest.mark.parametrize("theme", ["light", "dark"])
def test_every_preset_meets_wcag_aa(browser: Any, scene: RunningServer, theme: str) -> None:
    OUTPUT.mkdir(parents=True, exist_ok=True)
    page = browser.new_page(viewport={"width": 1920, "height": 1080})  # no bypass_csp: the page as users get it
    page.goto(scene.page_url("lab"))
    page.evaluate(f"localStorage.clear(); localStorage.setItem('pitchside.theme', '{theme}')")
    found = {}
    for preset in ("match", "lab", "replay", "all"):
        page.goto(f"{scene.url}/?preset={preset}&robot=r1")
        wait_for(lambda: page.locator('.card[data-robot="r2"], #grid .panel').count() > 0 and page.evaluate(
            "document.querySelectorAll('#grid .panel').length > 3"), 30.0, 0.2, f"{preset}: panels")
        assert page.evaluate("document.documentElement.classList.contains('dark')") == (theme == "dark")
        if preset in ("replay", "all"):  # the state graph drawn, with a current state
            wait_for(lambda: page.locator(".hcm-node.current").count() == 1, 30.0, 0.2, "the HCM graph")
            contrast = svg_state_contrast(page)
            assert contrast and all(c["ratio"] >= 4.5 for c in contrast), contrast
        if preset == "match":
            wait_for(lambda: page.locator('.card[data-robot="r2"]').count() == 1, 30.0, 0.2, "team cards")
        page.screenshot(path=str(OUTPUT / f"{preset}-{theme}.png"))
        found[preset] = serious_violations(page)
    (OUTPUT / f"axe-{theme}.json").write_text(json.dumps(found, indent=1))  # what to fix, when anything
    assert found == {"match": [], "lab": [], "replay": [], "all": []}, found


def test_the_theme_is_remembered(browser: Any, scene: RunningServer) -> None:
    page = browser.new_page(viewport={"width": 1920, "height": 1080})
    page.goto(scene.page_url("match"))
    page.evaluate("localStorage.clear()")
    page.reload()
    # the button is in the page's HTML; app.js gives it its handler when it builds the panels (a loaded machine
    # once took longer than the click)
    page.wait_for_selector('[data-panel="field"]')
    assert page.evaluate("document.documentElement.classList.contains('dark')") is False
    page.click("#theme-toggle")
    assert page.evaluate("document.documentElement.classList.contains('dark')") is True
    page.reload()
    page.wait_for_selector('[data-panel="field"]')
    assert page.evaluate("document.documentElement.classList.contains('dark')") is True
    assert page.get_attribute("#theme-toggle", "aria-pressed") == "true"
