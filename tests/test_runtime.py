"""The node runtime over real Zenoh on loopback: topics, parameters, actions, services, diagnostics."""

from __future__ import annotations

import struct
import subprocess
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import zenoh

import schemas
from robot_nodes.runtime import (
    ActionClient,
    BusConfig,
    GoalStatus,
    Node,
    ParameterClient,
    ParameterError,
    ServerGoal,
    ServiceError,
    call_service,
    open_session,
    param,
)
from robot_nodes.runtime.node import QUEUE_DEPTH
from tests.support import REPO
from tests.waiting import wait_for
from wire import keys
from wire.parameters import NodeSilent, StaleRevision


class Listener(Node):
    name = "listener"

    def setup(self) -> None:
        self.seqs: list[int] = []
        self.diagnostics: list[object] = []
        self.subscribe("joint_states", lambda msg: self.seqs.append(int(msg.position[0])))
        self.subscribe("diagnostics", self.diagnostics.append)


def start_talker(endpoint: str, *extra: str) -> subprocess.Popen[bytes]:
    return subprocess.Popen([sys.executable, "-m", "tests.proc_nodes", "talker", "--connect", endpoint, *extra],
                            cwd=REPO)


@pytest.fixture
def talker_process(router_endpoint: str) -> Iterator[subprocess.Popen[bytes]]:
    proc = start_talker(router_endpoint)
    yield proc
    proc.terminate()
    proc.wait(10)


def test_two_processes_exchange_messages_in_order(bus: BusConfig, talker_process: subprocess.Popen[bytes]) -> None:
    listener = Listener(bus=bus).start()
    try:
        wait_for(lambda: len(listener.seqs) >= 300, timeout=20, what="300 messages from the talker process")
        seqs = list(listener.seqs)
        assert seqs == list(range(seqs[0], seqs[0] + len(seqs))), "messages lost or out of order"
    finally:
        listener.shutdown()


def test_terminated_node_exits_cleanly(router_endpoint: str) -> None:
    proc = start_talker(router_endpoint)
    with open_session(BusConfig(connect=[router_endpoint])) as session:
        client = ParameterClient(session, "robot1")
        wait_for(lambda: "talker" in client.nodes(), timeout=15, what="talker up")
    proc.terminate()
    assert proc.wait(10) == 0


@dataclass
class GainParams:
    gain: float = param(1.0, range=(0.0, 2.0), doc="a gain")
    mode: str = param("soft", choices=["soft", "hard"], doc="a mode")
    enabled: bool = param(True, doc="a switch")
    count: int = param(3, range=(0, 10), doc="a count")
    wiring: str = param("fixed", startup=True, doc="read once at start-up")


class Tunable(Node):
    name = "tunable"
    Params = GainParams

    def setup(self) -> None:
        self.seen_changes: list[dict[str, object]] = []

    def on_parameters_changed(self, changed: dict[str, object]) -> None:
        self.seen_changes.append(changed)


def test_parameter_requests_from_the_bus_change_no_startup_value_and_bad_ones_are_counted(
        bus: BusConfig, tmp_path: Path) -> None:
    """The node saves to its own file only (no request names a path); a request that does not decode gets an error
    reply and is counted, and the node goes on answering."""
    yaml_path = tmp_path / "params.yaml"
    yaml_path.write_text("tunable:\n  gain: 1.5\n")
    node = Tunable(bus=bus, params_file=yaml_path).start()
    try:
        with open_session(bus) as session:
            client = ParameterClient(session, "robot1")
            with pytest.raises(ParameterError, match="read once when tunable starts"):
                client.set("tunable", {"wiring": "other"})
            client.set("tunable", {"wiring": "fixed"})  # the value it has: no change, no refusal
            client.set("tunable", {"gain": 0.5})
            client.reset("tunable")  # every parameter that may change live
            assert client.get("tunable", "gain") == 1.0 and client.get("tunable", "wiring") == "fixed"
            assert {p["name"]: p["startup"] for p in client.describe("tunable")}["wiring"] is True
            set_key = (f"{keys.domain_id()}/robot1/tunable/set_parameters/rcl_interfaces::srv::dds_::SetParameters_/"
                       f"{schemas.codec.type_hash('rcl_interfaces/srv/SetParameters')}")
            attachment = struct.pack("<qqB", 1, 0, 16) + bytes(16)
            replies = list(session.get(set_key, payload=b"\x00\x01\x00\x00" + b"\xff" * 7, attachment=attachment,
                                       timeout=5.0))
            assert replies and replies[0].err is not None  # an error reply with the reason, not silence
            wait_for(lambda: node._parameter_server.bad_requests == 1, what="the bad request counted")
            assert client.get("tunable", "gain") == 1.0  # still answering
    finally:
        node.shutdown()


def test_parameters_list_get_set_save_reload(bus: BusConfig, tmp_path: Path) -> None:
    yaml_path = tmp_path / "params.yaml"
    yaml_path.write_text("other_node:\n  x: 1\ntunable:\n  gain: 1.5\n")
    node = Tunable(bus=bus, params_file=yaml_path).start()
    try:
        with open_session(bus) as session:
            client = ParameterClient(session, "robot1")
            listed = {p["name"]: p for p in client.describe("tunable")}
            assert listed["gain"]["value"] == 1.5 and listed["gain"]["default"] == 1.0
            assert listed["gain"]["range"] == [0.0, 2.0] and listed["mode"]["choices"] == ["soft", "hard"]
            assert listed["gain"]["doc"] == "a gain"

            client.set("tunable", {"gain": 0.25, "mode": "hard"})
            assert client.get("tunable", "gain") == 0.25
            wait_for(lambda: node.seen_changes, what="change callback")
            assert node.params.mode == "hard"

            with pytest.raises(ParameterError, match=r"out of range \[0.0, 2.0\]") as refused:
                client.set("tunable", {"gain": 7.0, "count": 4})
            assert type(refused.value) is ParameterError  # the value itself, not a conflict
            assert client.get("tunable", "gain") == 0.25 and client.get("tunable", "count") == 3
            with pytest.raises(ParameterError, match="not one of"):
                client.set("tunable", {"mode": "medium"})
            with pytest.raises(ParameterError, match="must be an integer"):
                client.set("tunable", {"count": 2.5})
            with pytest.raises(ParameterError, match="no parameter 'nope'"):
                client.set("tunable", {"nope": 1})

            revision = {p["name"]: p["revision"] for p in client.describe("tunable")}["gain"]
            client.set("tunable", {"gain": 0.5}, revisions={"gain": revision})
            with pytest.raises(StaleRevision, match="changed meanwhile"):
                client.set("tunable", {"gain": 0.75}, revisions={"gain": revision})
            assert client.get("tunable", "gain") == 0.5
            with pytest.raises(NodeSilent, match="did not answer"):
                ParameterClient(session, "robot1", timeout=0.3).describe("no_such_node")

            client.save("tunable")
    finally:
        node.shutdown()
    text = yaml_path.read_text()
    assert "other_node" in text, "saving must keep the other nodes' sections"
    reloaded = Tunable(bus=bus, params_file=yaml_path)
    try:
        assert reloaded.params.gain == 0.5 and reloaded.params.mode == "hard"
    finally:
        reloaded.shutdown()


def test_out_of_range_value_in_yaml_is_refused(bus: BusConfig, tmp_path: Path) -> None:
    yaml_path = tmp_path / "params.yaml"
    yaml_path.write_text("tunable:\n  gain: 9\n")
    with pytest.raises(ParameterError, match="out of range"):
        Tunable(bus=bus, params_file=yaml_path)


GOAL = "humanoid_league_msgs/action/PlayAnimation_Goal"
RESULT = "humanoid_league_msgs/action/PlayAnimation_Result"
FEEDBACK = "humanoid_league_msgs/action/PlayAnimation_Feedback"


class Player(Node):
    """Plays fake animations: 10 feedback steps at 50 Hz; refuses 'forbidden'."""

    name = "player"

    def setup(self) -> None:
        self.active: ServerGoal | None = None
        self.progress = 0
        self.server = self.action_server("animation", self.on_goal, self.on_cancel)
        self.timer(self.step, rate_hz=50)

    def on_goal(self, goal: ServerGoal) -> str | None:
        if goal.goal.animation == "forbidden":
            return "animation 'forbidden' does not exist"
        if self.active is not None and not self.active.done and not goal.goal.hcm:
            return "busy; only an HCM goal may preempt"
        self.active, self.progress = goal, 0
        return None

    def on_cancel(self, goal: ServerGoal) -> None:
        goal.canceled(schemas.make(RESULT, successful=False, message="canceled"))

    def step(self) -> None:
        goal = self.active
        if goal is None or goal.done:
            return
        self.progress += 1
        goal.publish_feedback(schemas.make(FEEDBACK, percent_done=self.progress * 10.0))
        if self.progress >= 10:
            goal.succeed(schemas.make(RESULT, successful=True, message=goal.goal.animation))


def test_actions_feedback_preemption_cancel_reject(bus: BusConfig) -> None:
    player = Player(bus=bus).start()
    try:
        with open_session(bus) as session:
            client = ActionClient(session, "robot1", "animation")
            done = client.send_goal(schemas.make(GOAL, animation="wave"))
            status, result = done.wait_result(10)
            assert status == GoalStatus.SUCCEEDED and result.successful and result.message == "wave"
            # feedback and result travel apart (ROS 2's protocol): the last feedback may follow the result
            wait_for(lambda: len(done.feedback) == 10, what="all ten feedback messages")
            assert [round(f.percent_done) for f in done.feedback][-1] == 100

            rejected = client.send_goal(schemas.make(GOAL, animation="forbidden"))
            assert rejected.wait_accepted(5) is False and "does not exist" in rejected.reason

            first = client.send_goal(schemas.make(GOAL, animation="long"))
            assert first.wait_accepted(5)
            polite = client.send_goal(schemas.make(GOAL, animation="other"))
            assert polite.wait_accepted(5) is False and "busy" in polite.reason
            preempting = client.send_goal(schemas.make(GOAL, animation="getup", hcm=True))
            assert preempting.wait_accepted(5)
            assert first.wait_result(5)[0] == GoalStatus.ABORTED  # preempted: ROS 2 has no status of its own for it
            assert preempting.wait_result(10)[0] == GoalStatus.SUCCEEDED

            to_cancel = client.send_goal(schemas.make(GOAL, animation="long"))
            assert to_cancel.wait_accepted(5)
            assert to_cancel.cancel()
            status, result = to_cancel.wait_result(5)
            assert status == GoalStatus.CANCELED and result.message == "canceled"
            client.close()
    finally:
        player.shutdown()


class Penalizer(Node):
    name = "pause"

    def setup(self) -> None:
        self.service("manual_penalize", self.on_penalize)

    def on_penalize(self, request: object) -> object:
        value = request.penalize  # type: ignore[attr-defined]
        if value > 2:
            raise ValueError(f"penalize must be OFF, ON or SWITCH, not {value}")
        return schemas.make("humanoid_league_msgs/srv/ManualPenalize_Response", penalized=value == 1)


def test_service_call_and_refusal(bus: BusConfig) -> None:
    node = Penalizer(bus=bus).start()
    request = "humanoid_league_msgs/srv/ManualPenalize_Request"
    try:
        with open_session(bus) as session:
            assert call_service(session, "robot1", "manual_penalize", schemas.make(request, penalize=1)).penalized
            with pytest.raises(ServiceError, match="not 7"):
                call_service(session, "robot1", "manual_penalize", schemas.make(request, penalize=7))
            with pytest.raises(ServiceError, match="no answer"):
                call_service(session, "robot9", "manual_penalize", schemas.make(request), timeout=0.5)
    finally:
        node.shutdown()


class QuietReporter(Node):
    """Reports its diagnostics once a minute."""

    name = "quiet"
    diagnostics_period = 60.0


def test_a_started_node_reports_at_once_not_a_diagnostics_period_later(bus: BusConfig) -> None:
    listener = Listener(bus=bus).start()
    quiet = QuietReporter(bus=bus)
    try:
        quiet.start()
        wait_for(lambda: any(s.name == "robot1/quiet" for d in listener.diagnostics for s in d.status),  # type: ignore[attr-defined]
                 timeout=10, what="the first diagnostics of a node that reports once a minute")
    finally:
        quiet.shutdown()
        listener.shutdown()


def test_invalid_cdr_is_counted_in_diagnostics_and_node_survives(bus: BusConfig) -> None:
    listener = Listener(bus=bus).start()
    try:
        with open_session(bus) as session:
            key = keys.topic_key("robot1", "joint_states")
            wait_for(lambda: listener.diagnostics, timeout=5, what="first diagnostics")
            probe = schemas.encode(schemas.make("sensor_msgs/msg/JointState", name=["seq"], position=[7.0]))
            wait_for(lambda: session.put(key, probe) or 7 in listener.seqs, timeout=5, interval=0.05,
                     what="this session's messages reach the listener")  # so neither garbage put is lost
            session.put(key, b"\x00\x01\x00\x00garbage that is not a JointState")
            session.put(key, b"")

            def decode_errors() -> int:
                latest = listener.diagnostics[-1]
                values = {kv.key: kv.value for kv in latest.status[0].values}  # type: ignore[attr-defined]
                return int(values["decode_errors"])

            wait_for(lambda: decode_errors() == 2, timeout=5, what="decode errors reported")
            assert "not a valid sensor_msgs/msg/JointState" in listener.last_error
            good = schemas.make("sensor_msgs/msg/JointState", name=["seq"], position=[42.0])
            session.put(key, schemas.encode(good))
            wait_for(lambda: 42 in listener.seqs, timeout=5, what="a valid message after garbage")
    finally:
        listener.shutdown()


def test_session_config_has_no_multicast() -> None:
    conf = BusConfig(connect=["tcp/127.0.0.1:1"]).to_zenoh()
    assert '"enabled":false' in conf.get_json("scouting/multicast").replace(" ", "")
    assert isinstance(conf, zenoh.Config)


class StuckNode(Node):
    """A node whose handler blocks until the test lets it go: it falls behind its topic."""

    name = "stuck"

    def setup(self) -> None:
        self.release = threading.Event()
        self.got: list[float] = []
        self.sub = self.subscribe("joint_states", self.on_joints)

    def on_joints(self, msg: Any) -> None:
        self.release.wait(30.0)
        self.got.append(float(msg.position[0]))


@pytest.mark.parametrize("layout", ["composed", "split"])
def test_a_node_that_falls_behind_keeps_at_most_queue_depth_messages_and_counts_the_rest(
        bus: BusConfig, layout: str) -> None:
    """A handler that blocks must not make its process grow without end (a ROS 2 subscription's history depth):
    what waits for the loop is bounded, and what did not fit is counted in the node's diagnostics."""
    with open_session(bus) as session:
        stuck = StuckNode(bus=session if layout == "composed" else bus).start()
        sender = Node("robot1", bus=session if layout == "composed" else bus)
        try:
            pub = sender.publisher("joint_states")
            sent = 0

            def send(n: int) -> None:
                nonlocal sent
                for _ in range(n):
                    sent += 1
                    pub.publish(schemas.make("sensor_msgs/msg/JointState", name=["seq"], position=[float(sent)]))

            wait_for(lambda: send(1) or stuck.sub.count > 0, 10.0, 0.05, what="the first message in the handler")
            send(QUEUE_DEPTH + 500)
            wait_for(lambda: stuck.sub.overflowed >= 400, 10.0, what="messages beyond the depth dropped and counted")
            assert stuck.sub.queued <= QUEUE_DEPTH
            stuck.release.set()
            wait_for(lambda: stuck.sub.queued == 0, 20.0, what="the backlog delivered")
            assert QUEUE_DEPTH <= len(stuck.got) <= QUEUE_DEPTH + 100 and stuck.got == sorted(stuck.got)
            reported: list[str] = []

            def on_diagnostics(sample: zenoh.Sample) -> None:
                msg = schemas.decode(sample.payload.to_bytes(), "diagnostic_msgs/msg/DiagnosticArray")
                for status in msg.status:
                    if status.name == "robot1/stuck":
                        reported.extend(kv.value for kv in status.values if kv.key == "queue_overflows")

            with open_session(bus) as outside:  # the composed nodes' messages leave their session for others only
                outside.declare_subscriber(keys.topic_key("robot1", "diagnostics"), on_diagnostics)
                wait_for(lambda: reported and int(reported[-1]) == stuck.sub.overflowed, 5.0,
                         what="the drops in the node's diagnostics")
        finally:
            stuck.release.set()
            sender.shutdown()
            stuck.shutdown()
