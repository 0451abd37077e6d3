"""The parameters panel in chromium follows changes made elsewhere (another client over Zenoh, a reset, the node
itself) within seconds, and never overwrites an input the user is typing into; the threshold plot takes any
numeric field of any topic. Real server, real HCM node on Zenoh, real chromium."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import zenoh

from robot_nodes.hcm.node import HcmNode
from robot_nodes.runtime import BusConfig, ParameterClient
from tests.dashboard_server import RunningServer, dashboard_server
from tests.waiting import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.browser]
TIMEOUT_MS = 30_000
PANEL = '[data-panel="parameters"]'
FOLLOW_MS = 5_000  # "within a few seconds"


@pytest.fixture
def server(router_endpoint: str, tmp_path: Path) -> Iterator[RunningServer]:
    with dashboard_server(["--connect", router_endpoint, "--no-telemetry"], tmp_path) as running:
        yield running


@pytest.fixture
def hcm(bus: BusConfig) -> Iterator[HcmNode]:
    node = HcmNode("p1", bus).start()
    yield node
    node.shutdown()


def panel_page(browser: Any, server: RunningServer, robot: str) -> Any:
    page = browser.new_page(bypass_csp=True, viewport={"width": 1400, "height": 2000})
    page.errors = []
    page.on("pageerror", lambda exc: page.errors.append(str(exc)))
    page.goto(server.page_url("all"))
    page.evaluate(f"localStorage.clear(); localStorage.setItem('pitchside.focus', '{robot}'); "
                  "localStorage.setItem('pitchside.layout', JSON.stringify({columns: 1, panels: ["
                  "{id: 'parameters', w: 1, h: 8}]}))")
    page.reload()
    return page


def row(node: str, name: str) -> str:
    return f'{PANEL} tr[data-param="{node}/{name}"]'


def wait_shown(page: Any, node: str, name: str, value: str, revision: int, what: str) -> None:
    """Until the row's input shows value and its revision label says revision (FOLLOW_MS)."""
    r = row(node, name)
    try:
        page.wait_for_function(
            f"""(() => {{ const row = document.querySelector('{r}');
                return row && row.querySelector('input[data-role="value"]').value === '{value}'
                    && row.querySelector('[data-role="revision"]').textContent === 'rev {revision}'; }})()""",
            timeout=FOLLOW_MS)
    except Exception as exc:
        shown = page.evaluate(f"""(() => {{ const row = document.querySelector('{r}');
            return row && [row.querySelector('input[data-role="value"]').value,
                           row.querySelector('[data-role="revision"]').textContent]; }})()""")
        raise AssertionError(f"{what}: wanted {value} rev {revision} within {FOLLOW_MS} ms, the panel shows "
                             f"{shown}") from exc


def test_panel_follows_changes_made_elsewhere(browser: Any, server: RunningServer, hcm: HcmNode,
                                              client: zenoh.Session) -> None:
    params = ParameterClient(client, "p1")
    page = panel_page(browser, server, "p1")
    page.wait_for_selector(row("hcm", "falling_gyro_pitch"), timeout=TIMEOUT_MS)
    wait_shown(page, "hcm", "falling_gyro_pitch", "7", 0, "as read")
    page.wait_for_function("window.pitchside.params && typeof window.pitchside.params.events === 'number'",
                           timeout=TIMEOUT_MS)

    # another client sets a value over Zenoh: the panel shows it and its revision; so it does a reset
    params.set("hcm", {"falling_gyro_pitch": 11.5})
    wait_shown(page, "hcm", "falling_gyro_pitch", "11.5", 1, "a client's set")
    params.reset("hcm", ["falling_gyro_pitch"])
    wait_shown(page, "hcm", "falling_gyro_pitch", "7", 2, "a client's reset")
    # the node changes its own parameter
    hcm.parameters.set({"upright_deg": 35.0})
    wait_shown(page, "hcm", "upright_deg", "35", 1, "the node's own change")
    # the slider of a ranged parameter follows too (to its nearest step)
    slider = float(page.locator(f'{row("hcm", "upright_deg")} input[data-role="slider"]').input_value())
    assert slider == pytest.approx(35.0, abs=0.5)

    # the user is typing when someone else writes: the input keeps the user's text, the other value is shown beside
    value = page.locator(f'{row("hcm", "falling_gyro_pitch")} input[data-role="value"]')
    value.click()
    value.fill("9")
    params.set("hcm", {"falling_gyro_pitch": 12.5})
    elsewhere = f'{row("hcm", "falling_gyro_pitch")} [data-role="elsewhere"]'
    page.wait_for_selector(f'{elsewhere}:has-text("changed elsewhere to 12.5 (rev 3)")', timeout=FOLLOW_MS)
    assert value.input_value() == "9"
    assert page.locator(f'{row("hcm", "falling_gyro_pitch")} [data-role="revision"]').text_content() == "rev 2"
    # committing the typed value is a write based on the old revision: refused, and the panel shows theirs
    value.press("Tab")
    page.wait_for_selector(f'{row("hcm", "falling_gyro_pitch")} .param-error:has-text("changed meanwhile")',
                           timeout=TIMEOUT_MS)
    assert params.get("hcm", "falling_gyro_pitch") == 12.5
    wait_shown(page, "hcm", "falling_gyro_pitch", "12.5", 3, "theirs after the refusal")
    assert page.locator(elsewhere).text_content() == ""

    # typing, then leaving the input without a change: the value made elsewhere meanwhile appears on leaving
    value.click()
    params.set("hcm", {"falling_gyro_pitch": 13.0})
    page.wait_for_selector(f'{elsewhere}:has-text("13")', timeout=FOLLOW_MS)
    assert value.input_value() == "12.5"
    page.locator(f'{PANEL} [data-role="status"]').click()  # focus elsewhere, no change event
    wait_shown(page, "hcm", "falling_gyro_pitch", "13", 4, "the deferred value after leaving the input")
    assert wait_for(lambda: params.get("hcm", "falling_gyro_pitch") == 13.0, 5.0, 0.1, "nothing written back")
    assert not page.errors, page.errors


def test_threshold_line_over_any_numeric_field_of_any_topic(browser: Any, server: RunningServer, hcm: HcmNode,
                                                            bus: BusConfig, client: zenoh.Session) -> None:
    from tests.teststand import TestStand

    stand = TestStand("p1", bus, overrides={"rate_hz": 20.0, "joints": "HeadPan,LKnee,RKnee"}).start()
    try:
        page = panel_page(browser, server, "p1")
        page.wait_for_selector(row("hcm", "falling_gyro_pitch"), timeout=TIMEOUT_MS)
        page.locator(f"{PANEL} .lab-plot summary").click()
        topics = f'{PANEL} [data-role="topic"]'
        # the robot's topics are offered, not only the IMU: joint_states of the test stand, robot_state, diagnostics
        page.wait_for_selector(f'{topics} option[value="joint_states"]', state="attached", timeout=TIMEOUT_MS)
        page.wait_for_selector(f'{topics} option[value="diagnostics"]', state="attached", timeout=TIMEOUT_MS)
        page.select_option(topics, "joint_states")
        fields = f'{PANEL} [data-role="field"]'
        page.wait_for_selector(f'{fields} option[value="position/2"]', state="attached", timeout=TIMEOUT_MS)
        assert page.locator(f'{fields} option[value="position/2"]').text_content() == "position/2 (RKnee)"
        page.select_option(fields, "position/2")
        page.select_option(f'{PANEL} [data-role="threshold"]', "hcm/upright_deg")
        page.locator(f'{PANEL} [data-role="both-signs"]').uncheck()

        # the plot draws the chosen field (the newest value equals the newest message's) and the parameter's line
        page.wait_for_function("""(() => { const d = window.pitchside.params.drawn;  // redrawn after the choices
            return (d?.points ?? 0) >= 10 && d.field === 'position/2' && d.lines?.length === 1; })()""",
                               timeout=TIMEOUT_MS)
        drawn = page.evaluate("""(() => { const p = window.pitchside.params;
            return {...p.drawn, latest: window.pitchside.store.get('p1', 'joint_states').data.position[2]}; })()""")
        assert drawn["topic"] == "joint_states" and drawn["field"] == "position/2"
        assert abs(drawn["last"]) <= 0.3 + 1e-9  # the stand's joints swing within +-0.3 rad
        assert drawn["lines"] == [30.0]  # upright_deg's value, one line without the ±
        series = page.evaluate("window.pitchside.params.series.map((s) => s[1])")
        assert all(abs(v) <= 0.3 + 1e-9 for v in series) and len(set(series)) > 3  # a moving joint, not a constant

        # the line follows the parameter, changed from elsewhere
        ParameterClient(client, "p1").set("hcm", {"upright_deg": 40.0})
        page.wait_for_function("JSON.stringify(window.pitchside.params.drawn?.lines) === '[40]'", timeout=FOLLOW_MS)

        # another topic and a scalar field: robot_state's state
        page.select_option(topics, "robot_state")
        page.wait_for_selector(f'{fields} option[value="state"]', state="attached", timeout=TIMEOUT_MS)
        page.select_option(fields, "state")
        page.wait_for_function("window.pitchside.params.drawn?.field === 'state' && "
                               "window.pitchside.params.drawn.points >= 3", timeout=TIMEOUT_MS)
        assert not page.errors, page.errors
    finally:
        stand.shutdown()
