"""The HCM state graph in Debian's chromium at 1920x1080: the real HCM's 17 states and 62 transitions, laid out by
Graphviz, drawn without overlaps, names in full and readable at the panel's default size in the Replay and the
All-panels layouts, no edge through a state; current state, last transitions and triggers shown."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

import schemas
from robot_nodes.hcm.state_machine import HcmState, build_transitions
from robot_nodes.runtime import BusConfig, Node
from tests.dashboard_server import RunningServer, dashboard_server
from tests.state_graph_view import measure_state_graph
from tests.support import REPO
from tests.waiting import wait_for

OUTPUT = REPO / "test-output"
HCM_STATES = [s.value for s in HcmState]
HCM_TRANSITIONS = [(t.source.value, t.target.value, t.condition) for t in build_transitions()]
HISTORY = ["STARTUP", "CONTROLLABLE", "WALKING", "FALLING", "FALLEN", "GETTING_UP"]
HOSTILE = ['<img src=x onerror="window.pwned=1">', "A_VERY_LONG_STATE_NAME_THAT_STILL_FITS_ITS_BOX"]
pytestmark = [pytest.mark.slow, pytest.mark.browser]


class HcmGraphStand(Node):
    """The real HCM's graph, a history that walked, fell and is getting up; another robot with hostile names."""

    __test__ = False
    name = "graphstand"

    def setup(self) -> None:
        self.pub = self.publisher("hcm_graph")
        self.timer(self.tick, rate_hz=5.0)

    def tick(self) -> None:
        hostile = self.robot_id == "evil"
        states = [*HCM_STATES, *HOSTILE] if hostile else HCM_STATES
        transitions = [*HCM_TRANSITIONS, (HOSTILE[0], HOSTILE[1], "<b>bold</b>")] if hostile else HCM_TRANSITIONS
        stamps = [schemas.make("builtin_interfaces/msg/Time", sec=1_700_000_000 + i) for i in range(len(HISTORY))]
        self.pub.publish(schemas.make(
            "pitchside_msgs/msg/StateMachineGraph", name="hcm", states=states,
            transition_from=[t[0] for t in transitions], transition_to=[t[1] for t in transitions],
            transition_condition=[t[2] for t in transitions], current=HISTORY[-1], history_states=HISTORY,
            history_stamps=stamps))


@pytest.fixture
def server(router_endpoint: str, bus: BusConfig, tmp_path: Path) -> Iterator[RunningServer]:
    stands = [HcmGraphStand("r1", bus).start(), HcmGraphStand("evil", bus).start()]
    try:
        with dashboard_server(["--connect", router_endpoint, "--no-telemetry"], tmp_path) as running:
            yield running
    finally:
        for stand in stands:
            stand.shutdown()


def _open(browser: Any, server: RunningServer, preset: str, robot: str) -> Any:
    page = browser.new_page(viewport={"width": 1920, "height": 1080})  # the page's own CSP in force
    page.errors = []
    page.on("pageerror", lambda exc: page.errors.append(str(exc)))
    page.goto(f"{server.login_url}&preset={preset}&robot={robot}")
    # polled from here: waiting inside the page would evaluate a string, which its CSP forbids
    wait_for(lambda: page.evaluate(f"window.pitchside?.stateGraphs?.hcm?.robot === '{robot}'"), 30.0, 0.2,
             f"the state graph of {robot} drawn")
    return page


@pytest.mark.parametrize("preset", ["replay", "all"])
def test_the_real_hcm_graph_is_readable_at_the_panels_default_size(browser: Any, server: RunningServer,
                                                                    preset: str) -> None:
    OUTPUT.mkdir(exist_ok=True)
    page = _open(browser, server, preset, "r1")
    page.wait_for_selector('.hcm-node.current[data-state="GETTING_UP"]')
    drawn = measure_state_graph(page)
    page.locator('section[data-panel="hcm"]').screenshot(path=str(OUTPUT / f"hcm-graph-{preset}.png"))
    assert (drawn["states"], drawn["edges"]) == (17, 62), drawn
    assert drawn["samples"] > 1000  # the edges were really followed
    assert drawn["problems"] == [], (drawn["problems"], page.evaluate(
        "[JSON.stringify(window.pitchside.stateGraphs.hcm), document.querySelector('.graph-view').clientWidth, "
        "document.querySelector('.graph-view').clientHeight]"))

    # the last transitions of the history, the newest strongest; the state before the current one marked
    last = page.eval_on_selector_all(".hcm-edge.last", "els => els.map(e => [e.dataset.from, e.dataset.to])")
    recent = page.eval_on_selector_all(".hcm-edge.recent", "els => els.map(e => [e.dataset.from, e.dataset.to])")
    assert last == [["FALLEN", "GETTING_UP"]]
    assert sorted(recent) == [["FALLING", "FALLEN"], ["WALKING", "FALLING"]]
    assert page.get_attribute(".hcm-node.previous", "data-state") == "FALLEN"
    assert page.locator(".history-list li").first.text_content().strip().endswith("GETTING_UP")

    # a transition's triggers on hover: the edge itself, and all edges of a hovered state
    point = page.evaluate("""() => {
        const p = document.querySelector('.hcm-edge[data-from="FALLEN"][data-to="GETTING_UP"]');
        const m = p.getPointAtLength(p.getTotalLength() / 2);
        const s = new DOMPoint(m.x, m.y).matrixTransform(p.getScreenCTM()); return [s.x, s.y]; }""")
    page.mouse.move(*point)  # the middle of the edge
    tip = page.locator('[data-panel="hcm"] .tip')
    assert "FALLEN → GETTING_UP" in tip.text_content() and "when lying on front or back" in tip.text_content()
    page.hover('.hcm-node[data-state="PENALTY"]')
    text = tip.text_content()
    assert "PENALTY → PENALTY_ANIMATION_OUT: unpenalized" in text and "PENALTY_ANIMATION_IN → PENALTY" in text
    assert page.locator(".hcm-edge.active").count() == 4  # shutdown, record, unpenalized out; animation done in
    assert not page.errors, page.errors


def test_names_from_the_bus_are_drawn_as_text(browser: Any, server: RunningServer) -> None:
    page = _open(browser, server, "replay", "evil")
    for name in HOSTILE:
        assert page.locator(".hcm-node").filter(has_text=name).count() == 1
    drawn = measure_state_graph(page)
    # two more, long states: wider than the panel at a readable size, so it scrolls (not judged here)
    problems = [p for p in drawn["problems"] if not p.endswith("outside the panel's visible area")]
    assert drawn["states"] == 19 and problems == [], drawn
    assert page.evaluate("window.pwned") is None and page.locator('[data-panel="hcm"] img').count() == 0
    assert not page.errors, page.errors
