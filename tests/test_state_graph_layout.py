"""The state graph layout (server.state_graph_layout): Graphviz's dot lays out any StateMachineGraph; names from the
bus stay text; too large graphs are refused with a reason; the endpoint serves the newest graph of a stream."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

import schemas
from robot_nodes.hcm.state_machine import HcmState, build_transitions
from robot_nodes.runtime import BusConfig, Node
from server.state_graph_layout import MAX_STATES, GraphTooLarge, StateBox, dot_quoted, layout
from tests.dashboard_server import RunningServer, dashboard_server
from tests.waiting import wait_for

HCM_STATES = [s.value for s in HcmState]
HCM_TRANSITIONS = [(t.source.value, t.target.value, t.condition) for t in build_transitions()]


def overlap(a: StateBox, b: StateBox) -> bool:
    return a.x < b.x + b.width and b.x < a.x + a.width and a.y < b.y + b.height and b.y < a.y + a.height


def test_the_hcm_is_layered_from_start_up_down_without_overlaps() -> None:
    drawn = layout(HCM_STATES, HCM_TRANSITIONS)
    boxes = {b.name: b for b in drawn.states}
    assert set(boxes) == set(HCM_STATES)
    assert not [(a.name, b.name) for a in drawn.states for b in drawn.states if a is not b and overlap(a, b)]
    for box in drawn.states:  # inside the drawing
        assert box.x >= 0 and box.x + box.width <= drawn.width + 0.5 and 0 <= box.y <= drawn.height
    # one drawn transition per (from, to), every trigger kept with it
    pairs = {(a, b) for a, b, _ in HCM_TRANSITIONS}
    assert {(t.from_state, t.to_state) for t in drawn.transitions} == pairs
    assert sum(len(t.conditions) for t in drawn.transitions) == len(HCM_TRANSITIONS)
    # the flow: start-up above standing above walking above falling; shutting down below everything it ends
    y = {name: box.y for name, box in boxes.items()}
    assert y["STARTUP"] < y["CONTROLLABLE"] < y["WALKING"] < y["FALLING"] < y["FALLEN"] < y["GETTING_UP"]
    assert y["PENALTY_ANIMATION_IN"] < y["PENALTY"]
    assert y["SHUTDOWN"] > max(v for k, v in y.items() if k not in ("SHUTDOWN", "HCM_OFF"))
    assert y["HCM_OFF"] > y["SHUTDOWN"]
    # each spline starts at its source box and its arrow ends at its target box
    for t in drawn.transitions:
        start = [float(v) for v in t.path[1:].split(" ")[0].split(",")]
        tip = t.head[1]
        for point, box in ((start, boxes[t.from_state]), (tip, boxes[t.to_state])):
            assert box.x - 2 <= point[0] <= box.x + box.width + 2 and box.y - 2 <= point[1] <= box.y + box.height + 2


def test_names_stay_text_and_reach_dot_only_quoted() -> None:
    assert dot_quoted('a"b\\N') == '"a\\"b\\\\N"'
    hostile = ['x" shape=none image="/etc/passwd', "\\N\\G", "<b>markup</b>", "ünïcode", "]; y -> z; z [label="]
    drawn = layout(hostile, [(hostile[0], hostile[1], "c\"1"), (hostile[1], hostile[2], "")])
    assert [b.name for b in drawn.states] == hostile  # exactly these boxes, nothing added by the names
    assert len({b.width for b in drawn.states}) > 1  # sized by their own text
    assert [t.conditions for t in drawn.transitions] == [('c"1',), ("",)]


def test_transitions_to_unknown_states_are_left_out_and_large_graphs_refused() -> None:
    drawn = layout(["A", "B"], [("A", "B", "go"), ("A", "NOWHERE", "lost")])
    assert [(t.from_state, t.to_state) for t in drawn.transitions] == [("A", "B")]
    with pytest.raises(GraphTooLarge, match=f"at most {MAX_STATES}"):
        layout([f"S{i}" for i in range(MAX_STATES + 1)], [])
    with pytest.raises(GraphTooLarge, match="characters"):
        layout(["A" * 500], [])


class GraphStand(Node):
    """Publishes the real HCM's graph and, on another topic, a joint state (not a graph)."""

    __test__ = False
    name = "graphstand"

    def setup(self) -> None:
        self.graph = self.publisher("hcm_graph")
        self.joints = self.publisher("joint_states")
        self.timer(self.tick, rate_hz=5.0)

    def tick(self) -> None:
        self.graph.publish(schemas.make(
            "pitchside_msgs/msg/StateMachineGraph", name="hcm", states=HCM_STATES,
            transition_from=[t[0] for t in HCM_TRANSITIONS], transition_to=[t[1] for t in HCM_TRANSITIONS],
            transition_condition=[t[2] for t in HCM_TRANSITIONS], current="WALKING"))
        self.joints.publish(schemas.make("sensor_msgs/msg/JointState", name=["a"], position=[0.0]))


@pytest.fixture
def server(router_endpoint: str, bus: BusConfig, tmp_path: Path) -> Iterator[RunningServer]:
    stand = GraphStand("g1", bus).start()
    try:
        with dashboard_server(["--connect", router_endpoint, "--no-telemetry"], tmp_path) as running:
            yield running
    finally:
        stand.shutdown()


def test_the_endpoint_lays_out_the_newest_graph_of_a_stream(server: RunningServer) -> None:
    http = server.http
    base = server.url
    answer = wait_for(lambda: (r := http.get(f"{base}/api/state-graphs/g1/hcm_graph")).status_code == 200 and r, 30.0,
                      0.2, "the HCM graph laid out")
    view = answer.json()
    assert (view["robot"], view["topic"], view["machine"]) == ("g1", "hcm_graph", "hcm")
    assert {s["name"] for s in view["states"]} == set(HCM_STATES) and len(view["transitions"]) == 62
    assert http.get(f"{base}/api/state-graphs/g1/joint_states").status_code == 422
    assert http.get(f"{base}/api/state-graphs/nobody/hcm_graph").status_code == 404
