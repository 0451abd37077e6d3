"""The parameters task as a team member does it in the lab (issues 21 and 51), in chromium at 1920x1080 with the
default layout, against real nodes started from a params.yaml with comments: find the walking node's step frequency
(the last of the nodes) by the dotted name the panel shows, change it, save it, revert it, counting the actions;
search by words and units, an old error gone with the next search; the own change is not "changed elsewhere"; save
keeps the file's comments and refreshes the diff; revert to file; undo restores exactly; reset-all asks first; every
column of every node's table is inside the panel. Real server, real nodes on Zenoh, real chromium."""

from __future__ import annotations

import socket
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import zenoh

from robot_nodes.hcm.node import HcmNode
from robot_nodes.hcm.pause import PauseNode
from robot_nodes.runtime import BusConfig, ParameterClient
from robot_nodes.telemetry.sender import TelemetryNode
from robot_nodes.walking.node import WalkingNode
from tests.dashboard_server import RunningServer, dashboard_server
from tests.support import REPO, free_port
from tests.waiting import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.browser]
TIMEOUT_MS = 30_000
OUTPUT = REPO / "test-output"
PANEL = '[data-panel="parameters"]'
ROBOT = "lab1"
PARAMS_YAML = """\
# Parameters of the lab robot; top-level keys are node names.
hcm:
  falling_gyro_pitch: 7.5  # rad/s, tuned after the new feet

# the walking engine, tuned on the lab's carpet
walking:
  # steps per second: faster trips on the carpet
  step_frequency: 2.0  # was 1.8 before 2026-11
  foot_lift: 0.03
"""


class Actions:
    """The user's actions, counted as the issue counts them: a click, or a typed entry (its Enter included)."""

    def __init__(self, page: Any) -> None:
        self.page = page
        self.count = 0

    def click(self, selector: str) -> None:
        self.page.click(selector)
        self.count += 1

    def enter(self, text: str) -> None:
        self.page.keyboard.type(text)
        self.page.keyboard.press("Enter")
        self.count += 1


@pytest.fixture
def server(router_endpoint: str, tmp_path: Path) -> Iterator[RunningServer]:
    with dashboard_server(["--connect", router_endpoint, "--no-telemetry"], tmp_path) as running:
        yield running


@pytest.fixture
def params_file(tmp_path: Path) -> Path:
    path = tmp_path / "params.yaml"
    path.write_text(PARAMS_YAML)
    return path


@pytest.fixture
def nodes(bus: BusConfig, params_file: Path) -> Iterator[list[Any]]:
    telemetry = {"destination": f"127.0.0.1:{free_port(socket.SOCK_DGRAM)}", "allow_dev_key": True}
    started: list[Any] = []
    try:
        for cls, overrides in ((HcmNode, None), (PauseNode, None), (TelemetryNode, telemetry), (WalkingNode, None)):
            started.append(cls(ROBOT, bus, params_file=params_file, overrides=overrides).start())
        yield started
    finally:
        for node in started:
            node.shutdown()


def row(node: str, name: str) -> str:
    return f'{PANEL} tr[data-param="{node}/{name}"]'


def value_of(page: Any, node: str, name: str) -> str:
    return str(page.locator(f'{row(node, name)} [data-role="value"]').input_value())


def wait_row(page: Any, node: str, name: str, value: str, revision: int) -> None:
    r = row(node, name)
    page.wait_for_function(f"""(() => {{ const row = document.querySelector('{r}');
        return row && row.querySelector('[data-role="value"]').value === '{value}'
            && row.querySelector('[data-role="revision"]').textContent === 'rev {revision}'; }})()""",
                           timeout=TIMEOUT_MS)


def test_find_change_save_revert_undo_reset(browser: Any, server: RunningServer, nodes: list[Any],
                                            params_file: Path, client: zenoh.Session) -> None:
    params = ParameterClient(client, ROBOT)
    page = browser.new_page(bypass_csp=True, viewport={"width": 1920, "height": 1080})
    page.errors = []
    page.on("pageerror", lambda exc: page.errors.append(str(exc)))
    page.goto(server.login_url)
    page.evaluate(f"localStorage.clear(); localStorage.setItem('pitchside.focus', '{ROBOT}')")  # the default layout
    page.reload()
    page.wait_for_selector(row("walking", "step_frequency"), state="attached", timeout=TIMEOUT_MS)

    # every column of every node's table lies inside the panel at its default width (the telemetry node's too)
    outside = page.evaluate(f"""(() => {{ const panel = document.querySelector('{PANEL}').getBoundingClientRect();
        return [...document.querySelectorAll('{PANEL} table.params th, {PANEL} table.params td')]
            .filter((c) => c.getBoundingClientRect().right > panel.right + 0.5)
            .map((c) => c.closest('[data-node]').dataset.node + ': ' + c.textContent.trim().slice(0, 30)); }})()""")
    assert outside == [], f"cells beyond the panel's right edge: {outside[:5]}"
    assert page.locator(f'{PANEL} [data-node="telemetry"] th:has-text("back to")').is_visible()
    # in a narrow panel the headers wrap inside their columns instead of running into the next one
    overlapping = page.evaluate(f"""(() => {{ const panel = document.querySelector('{PANEL}');
        panel.style.width = '360px';  // three quarters of the Lab preset's
        const out = [...panel.querySelectorAll('[data-node="walking"] table.params th')]
            .filter((th) => th.scrollWidth > th.clientWidth + 1).map((th) => th.textContent);
        panel.style.width = ''; return out; }})()""")
    assert overlapping == []

    # -- the task: find the walking node's step frequency and change it to 2.2 --------------------------------------
    act = Actions(page)
    act.click(f'{PANEL} [data-role="search"]')
    act.enter("walking.step")  # as the panel names it (the status line: walking.step_frequency = ...)
    # only the walking node's step frequency is left; Enter put the cursor into its value, selected
    assert page.locator(f'{PANEL} [data-role="found"]').text_content() == "1 of " + str(
        page.locator(f"{PANEL} tr[data-param]").count())
    assert page.locator(row("walking", "step_frequency")).is_visible()
    assert not page.locator(f'{PANEL} [data-node="hcm"]').is_visible()
    step = page.locator(f'{row("walking", "step_frequency")} [data-role="value"]')
    assert step.evaluate("(el) => el === document.activeElement && el.value === '2'")
    act.enter("2.2")
    wait_for(lambda: params.get("walking", "step_frequency") == 2.2, 20.0, 0.1, "the walking node took 2.2")
    wait_row(page, "walking", "step_frequency", "2.2", 1)
    # the write's reply says so (on a loaded machine it may come after the node's event has shown the value)
    page.wait_for_selector(f'{PANEL} [data-role="status"]:has-text("walking.step_frequency = 2.2")',
                           timeout=TIMEOUT_MS)
    assert act.count < 4, f"found and changed in {act.count} actions"
    # the change's own event arrived while the cursor is still in the input: not "changed elsewhere"
    page.wait_for_function("window.pitchside.params.ownEvents + window.pitchside.params.events >= 1",
                           timeout=TIMEOUT_MS)
    assert page.locator(f'{row("walking", "step_frequency")} [data-role="elsewhere"]').text_content() == ""

    # -- save: the file keeps its comments and order, the panel says so, the diff is refreshed ----------------------
    act.click(f'{PANEL} [data-node="walking"] button[data-act="save"]')
    page.wait_for_selector(f'{PANEL} [data-role="status"]:has-text("saved walking to {params_file}")',
                           timeout=TIMEOUT_MS)
    assert params_file.read_text() == PARAMS_YAML.replace("step_frequency: 2.0  #", "step_frequency: 2.2  #")
    page.wait_for_selector(f'{PANEL} [data-node="walking"] [data-role="matches"]:has-text("{params_file}")',
                           timeout=TIMEOUT_MS)
    # -- revert: the row's "default" takes it back to the node's default --------------------------------------------
    act.click(f'{row("walking", "step_frequency")} button[data-act="reset"]')
    wait_for(lambda: params.get("walking", "step_frequency") == 2.0, 20.0, 0.1, "back to the default 2.0")
    wait_row(page, "walking", "step_frequency", "2", 2)
    print(f"TASK parameters actions={act.count}")  # find, set, save, revert
    assert act.count <= 6, f"found, set, saved and reverted in {act.count} actions"

    # -- found as named: words of the description and units; an old error goes with the next search --------------
    search = page.locator(f'{PANEL} [data-role="search"]')
    search.fill("no such thing")
    search.press("Enter")
    page.wait_for_selector(f'{PANEL} .lab-status.bad:has-text("no parameter matches")', timeout=TIMEOUT_MS)
    search.fill("walking speed")  # "speed": what is per second (step_frequency: "single steps per second")
    assert not page.locator(f'{PANEL} .lab-status').evaluate("(el) => el.classList.contains('bad')")
    assert page.locator(f'{PANEL} .lab-status').text_content() == ""
    assert page.locator(row("walking", "step_frequency")).is_visible()
    assert not page.locator(row("walking", "foot_lift")).is_visible()
    assert not page.locator(f'{PANEL} [data-node="hcm"]').is_visible()
    search.fill("walking m")  # a unit: the walking node's lengths (foot_lift: "..., m"), not every word with an m
    assert page.locator(row("walking", "foot_lift")).is_visible()
    assert not page.locator(row("walking", "step_frequency")).is_visible()

    # -- a refusal's note goes with the next accepted change; revert to file; undo exactly --------------------------
    page.fill(f'{PANEL} [data-role="search"]', "foot lift")
    lift = page.locator(f'{row("walking", "foot_lift")} [data-role="value"]')
    lift.fill("0.5")
    lift.press("Enter")
    page.wait_for_selector(f'{row("walking", "foot_lift")} .param-error:has-text("out of range")', timeout=TIMEOUT_MS)
    lift.fill("0.0375")
    lift.press("Enter")
    wait_for(lambda: params.get("walking", "foot_lift") == 0.0375, 20.0, 0.1, "the node took 0.0375")
    page.wait_for_function(f"""document.querySelector('{row("walking", "foot_lift")} .param-error').textContent === ''
        && !document.querySelector('{PANEL} .lab-status').classList.contains('bad')""", timeout=TIMEOUT_MS)
    page.click(f'{row("walking", "foot_lift")} button[data-act="revert"]')
    wait_for(lambda: params.get("walking", "foot_lift") == 0.03, 20.0, 0.1, "reverted to the file's 0.03")
    wait_row(page, "walking", "foot_lift", "0.03", 2)
    page.click(f'{PANEL} button[data-act="undo"]')  # undoes the revert: exactly the value before it
    wait_for(lambda: params.get("walking", "foot_lift") == 0.0375, 20.0, 0.1, "undo: 0.0375 again")
    wait_row(page, "walking", "foot_lift", "0.0375", 3)
    page.click(f'{PANEL} button[data-act="undo"]')  # undoes the change: the value the node started with
    wait_for(lambda: params.get("walking", "foot_lift") == 0.03, 20.0, 0.1, "undo: 0.03 again")
    # someone else changes the value the next undo would restore: that undo is refused, theirs stays
    page.fill(f'{PANEL} [data-role="search"]', "")
    page.dispatch_event(f'{PANEL} [data-role="search"]', "input")
    assert page.locator(f'{PANEL} [data-node="hcm"]').is_visible()  # the search cleared: every node again
    params.set("walking", {"step_frequency": 2.4})
    wait_row(page, "walking", "step_frequency", "2.4", 3)
    assert page.locator(f'{row("walking", "step_frequency")} [data-role="elsewhere"]').text_content() == ""
    page.click(f'{PANEL} button[data-act="undo"]')
    page.wait_for_selector(f'{PANEL} .lab-status.bad:has-text("undo refused")', timeout=TIMEOUT_MS)
    assert params.get("walking", "step_frequency") == 2.4

    # -- reset all asks first: cancelled, nothing changes; confirmed, every value is its default; undo restores ----
    asked: list[str] = []

    def answer(accept: bool) -> None:
        """The next question the page asks is noted and answered (OK or Cancel)."""
        def on_dialog(dialog: Any) -> None:
            asked.append(dialog.message)
            if accept:
                dialog.accept()
            else:
                dialog.dismiss()
        page.once("dialog", on_dialog)

    answer(False)
    page.click(f'{PANEL} [data-node="walking"] button[data-act="reset-node"]')
    page.wait_for_selector(f'{PANEL} [data-role="status"]:has-text("cancelled")', timeout=TIMEOUT_MS)
    assert "step_frequency: 2.4 → 2" in asked[0], asked
    assert params.get("walking", "step_frequency") == 2.4
    answer(True)
    page.click(f'{PANEL} [data-node="walking"] button[data-act="reset-node"]')
    wait_for(lambda: params.get("walking", "step_frequency") == 2.0, 20.0, 0.1, "reset to the default 2.0")
    wait_row(page, "walking", "step_frequency", "2", 4)
    page.click(f'{PANEL} button[data-act="undo"]')
    wait_for(lambda: params.get("walking", "step_frequency") == 2.4, 20.0, 0.1, "undo of the reset: 2.4 again")
    # revert all to file asks too, and brings the saved 2.2 back
    answer(True)
    page.click(f'{PANEL} [data-node="walking"] button[data-act="revert-node"]')
    # (the question comes after the panel read the file: Playwright answers it while it waits in the page)
    page.wait_for_selector(f'{PANEL} [data-role="status"]:has-text("walking.step_frequency = 2.2")',
                           timeout=TIMEOUT_MS)
    wait_for(lambda: params.get("walking", "step_frequency") == 2.2, 20.0, 0.1, "reverted to the saved 2.2")
    assert f"revert walking to {params_file}" in asked[-1] and "step_frequency: 2.4 → 2.2" in asked[-1]
    OUTPUT.mkdir(exist_ok=True)
    page.locator(PANEL).screenshot(path=str(OUTPUT / "lab-parameters-task.png"))
    assert not page.errors, page.errors
