"""Nodes composed in one process: messages handed over as objects in publish order, CDR only for subscribers outside
the process, published messages frozen, and composed processes supervised like single nodes."""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import threading
import time
import types
from collections.abc import Iterator
from typing import Any

import pytest
import zenoh

import schemas
from robot_nodes.compose import FAILED_NODE_EXIT, ROBOT_SEPARATOR, parse_robots, robot_parser
from robot_nodes.launch import Launcher, RobotNodes, describe_exit, process_groups, robot_processes, shared_process
from robot_nodes.runtime import BusConfig, Node, ParameterClient, open_session
from robot_nodes.runtime.local_bus import THAWED, RemoteInterest
from schemas.std import JointState
from tests.proc_nodes import Talker
from tests.support import REPO
from tests.waiting import wait_for
from wire import keys


class Recorder(Node):
    """Keeps every joint_states object it gets, and what it was told to do to them."""

    name = "recorder"

    def setup(self) -> None:
        self.got: list[JointState] = []
        self.mutate = ""
        self.subscribe("joint_states", self.on_joint_states)

    def on_joint_states(self, msg: JointState) -> None:
        self.got.append(msg)
        if self.mutate == "array":
            msg.position[0] = -1.0  # in place: refused at once, the array is read-only
        elif self.mutate == "field":
            msg.name = ["changed"]  # a new value for a field: found by the frozen check


@pytest.fixture
def session(bus: BusConfig) -> Iterator[zenoh.Session]:
    with open_session(bus) as shared:
        yield shared


def started(*nodes: Node) -> list[Node]:
    return [node.start() for node in nodes]


def test_composed_nodes_get_the_published_objects_in_order_and_nothing_is_encoded(session: zenoh.Session) -> None:
    talker = Talker(bus=session, overrides={"rate_hz": 500.0})
    recorder = Recorder(bus=session)
    nodes = started(recorder, talker)
    try:
        wait_for(lambda: len(recorder.got) >= 200, 10.0, what="200 messages in the process")
        seqs = [int(m.position[0]) for m in recorder.got[:200]]
        assert seqs == list(range(seqs[0], seqs[0] + 200)), "in publish order, none lost"
        # the very object the talker built, not a decoded copy, and no CDR was made for anyone
        assert all(isinstance(m, JointState) for m in recorder.got)
        assert talker.pub.encoded == 0
        assert not recorder.got[0].position.flags.writeable
    finally:
        for node in nodes:
            node.shutdown()


def test_a_subscriber_outside_the_process_gets_cdr_only_while_it_listens(session: zenoh.Session,
                                                                         client: zenoh.Session) -> None:
    talker = Talker(bus=session, overrides={"rate_hz": 200.0})
    recorder = Recorder(bus=session)
    nodes = started(recorder, talker)
    outside: list[JointState] = []
    try:
        wait_for(lambda: len(recorder.got) >= 20, 10.0, what="in-process delivery")
        assert talker.pub.encoded == 0, "nobody outside: nothing encoded"
        sub = client.declare_subscriber(keys.topic_key("robot1", "joint_states"),
                                        lambda s: outside.append(schemas.decode(s.payload.to_bytes(), JointState)))
        wait_for(lambda: len(outside) >= 20, 10.0, what="CDR reaching the outside subscriber")
        seqs = [int(m.position[0]) for m in outside[:20]]
        assert seqs == list(range(seqs[0], seqs[0] + 20))
        sub.undeclare()
        wait_for(lambda: not talker.pub.has_subscribers or talker.pub._remote.matching is False, 5.0,
                 what="the matching status to drop")
        # a publish that read the status just before it dropped finishes its put: it is done once the talker
        # (one thread) has handed two more messages over
        seen = len(recorder.got)
        wait_for(lambda: len(recorder.got) >= seen + 2, 10.0, what="the talker's next messages")
        encoded = talker.pub.encoded
        seen = len(recorder.got)
        wait_for(lambda: len(recorder.got) >= seen + 50, 10.0, what="more in-process messages")
        assert talker.pub.encoded == encoded, "encoding stops when the outside subscriber leaves"
    finally:
        for node in nodes:
            node.shutdown()


class _StatusReadWhileASubscriberAppears:
    """A publisher whose first matching-status read is overtaken by the listener's report of a new subscriber: the
    interleaving Zenoh's own thread can make (the read returns the state of a moment before the report)."""

    def __init__(self) -> None:
        self.listener: Any = None

    def declare_matching_listener(self, callback: Any) -> Any:
        self.listener = callback
        return types.SimpleNamespace(undeclare=lambda: None)

    @property
    def matching_status(self) -> Any:
        before = types.SimpleNamespace(matching=False)
        self.listener(types.SimpleNamespace(matching=True))
        return before


def test_a_subscriber_that_appears_during_the_first_status_read_is_not_forgotten() -> None:
    told: list[bool] = []
    interest = RemoteInterest(_StatusReadWhileASubscriberAppears(), told.append)  # type: ignore[arg-type]
    assert interest.matching is True, "the listener's newer report lost to the older read: never sent to"
    assert told == [True]


def test_messages_from_outside_are_decoded_once_for_every_node_of_the_process(session: zenoh.Session,
                                                                              bus: BusConfig) -> None:
    first, second = Recorder(bus=session), Recorder(bus=session)
    talker = Talker(bus=bus, overrides={"rate_hz": 200.0})  # its own session: another process to the recorders
    nodes = started(first, second, talker)
    try:
        wait_for(lambda: len(first.got) >= 50 and len(second.got) >= 50, 10.0, what="both recorders fed")
        common = {id(m) for m in first.got} & {id(m) for m in second.got}
        assert len(common) >= 40, "one decoded object shared by both nodes of the process"
        assert talker.pub.encoded >= 50
    finally:
        for node in nodes:
            node.shutdown()


@pytest.mark.parametrize("how", ["array", "field"])
def test_a_node_that_changes_a_published_message_is_caught(session: zenoh.Session, how: str) -> None:
    """The rule of the in-process bus: a published message is frozen (robot_nodes/runtime/local_bus.py)."""
    assert os.environ.get("PITCHSIDE_CHECK_FROZEN") == "1", "the suite runs with the frozen check"
    talker = Talker(bus=session, overrides={"rate_hz": 100.0})
    careless, careful = Recorder(bus=session), Recorder(bus=session)
    careless.mutate = how
    nodes = started(careless, careful, talker)
    try:
        wait_for(lambda: careless.errors >= 3, 10.0, what="the change reported as the careless node's error")
        if how == "array":
            assert "read-only" in careless.last_error
            assert careful.errors == 0, "refused in place: the other node's copy never changed"
        else:
            assert "changed after it was published" in careless.last_error
            assert THAWED, "the frozen check notes it for the tests"
    finally:
        for node in nodes:
            node.shutdown()
        THAWED.clear()  # this test made them on purpose


def test_groups_of_a_robot() -> None:
    names = ["cm730", "hcm", "animation", "walking", "speaker"]
    assert process_groups(names, "none") == [[n] for n in names]
    assert process_groups(names, "all", ["cm730"]) == [["hcm", "animation", "walking", "speaker"], ["cm730"]]
    assert process_groups(names, "hcm+animation+walking") == [["hcm", "animation", "walking"], ["cm730"],
                                                               ["speaker"]]
    with pytest.raises(ValueError, match="every node of a group"):
        process_groups(names, "hcm+mitecom")
    with pytest.raises(ValueError, match="one group only"):
        process_groups(names, "hcm+animation,hcm+walking")


def composed(router: str, *nodes: str, extra: list[str] | None = None) -> list[str]:
    return [sys.executable, "-m", "robot_nodes.compose", *nodes, "--robot-id", "robot1", "--connect", router,
            *(extra or [])]


@pytest.mark.parametrize("layout", [[], ["--loop-per-node"]], ids=["one loop", "a loop per node"])
def test_a_composed_process_keeps_each_nodes_parameters_and_diagnostics(router_endpoint: str, client: zenoh.Session,
                                                                        layout: list[str]) -> None:
    diagnostics: dict[str, dict[str, str]] = {}
    echoes: list[int] = []

    def on_diagnostics(sample: zenoh.Sample) -> None:
        for status in schemas.decode(sample.payload.to_bytes(), "diagnostic_msgs/msg/DiagnosticArray").status:
            diagnostics[status.name] = {kv.key: kv.value for kv in status.values}

    client.declare_subscriber(keys.topic_key("robot1", "diagnostics"), on_diagnostics)
    client.declare_subscriber(keys.topic_key("robot1", "robot_state"), lambda s: echoes.append(1))
    proc = subprocess.Popen(composed(router_endpoint, "tests.proc_nodes:Talker", "tests.proc_nodes:Echo",
                                     extra=["--set", "talker.rate_hz=50", "--set", "talker.label=composed",
                                            *layout]),
                            cwd=REPO)
    try:
        wait_for(lambda: {"robot1/talker", "robot1/echo"} <= set(diagnostics), 30.0, what="both nodes' diagnostics")
        wait_for(lambda: len(echoes) >= 10, 10.0, what="the echo answering the talker inside the process")
        params = ParameterClient(client, "robot1")
        assert params.get("talker", "rate_hz") == 50.0 and params.get("talker", "label") == "composed"
        params.set("talker", {"rate_hz": 20.0})
        assert params.get("talker", "rate_hz") == 20.0
        assert params.describe("echo") == []  # a node of its own, without parameters
        assert {"talker", "echo"} <= set(params.nodes())
        if layout:  # a loop each: nothing shared to report
            assert "loop_shared_by" not in diagnostics["robot1/talker"]
        else:  # one loop: each node says so, and the longest callback another may have waited for
            wait_for(lambda: diagnostics["robot1/echo"].get("loop_shared_by") == "2", 10.0,
                     what="the nodes saying they share one loop")
            assert float(diagnostics["robot1/talker"]["loop_longest_call_ms"].split()[0]) < 1000.0
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(20) == 0, "a composed process stops cleanly on SIGTERM"


@pytest.mark.parametrize("layout", [[], ["--loop-per-node"]], ids=["one loop", "a loop per node"])
def test_a_composed_process_whose_node_stops_on_its_own_ends_naming_it(router_endpoint: str,
                                                                       layout: list[str]) -> None:
    out = subprocess.run(composed(router_endpoint, "tests.proc_nodes:Talker", "tests.proc_nodes:LeavesSoon",
                                  extra=layout), cwd=REPO, capture_output=True, text=True, timeout=60)
    assert out.returncode == FAILED_NODE_EXIT + 1, out.stderr
    assert "robot1/leaves_soon stopped on its own" in out.stderr


def test_a_bad_override_names_the_nodes_of_the_process(router_endpoint: str) -> None:
    out = subprocess.run(composed(router_endpoint, "tests.proc_nodes:Talker", extra=["--set", "rate_hz=5"]),
                         cwd=REPO, capture_output=True, text=True, timeout=60)
    assert out.returncode != 0 and "NODE.NAME=VALUE" in out.stderr and "tests.proc_nodes:Talker" in out.stderr


def test_the_supervisor_restarts_a_composed_process_and_names_the_failed_node(router_endpoint: str,
                                                                              caplog: pytest.LogCaptureFixture
                                                                              ) -> None:
    good = robot_processes("robot1", [["tests.proc_nodes:Talker", "tests.proc_nodes:Echo"]], [router_endpoint])
    bad = robot_processes("robot1", [["tests.proc_nodes:Talker", "tests.proc_nodes:BrokenAtStart"]],
                          [router_endpoint])
    assert good[0].members == ["Talker", "Echo"] and good[0].name == "robot1/Talker+Echo"
    launcher = Launcher([*good, *bad], max_delay=0.5)
    thread = threading.Thread(target=launcher.run, daemon=True)
    received: list[float] = []
    with caplog.at_level(logging.INFO, logger="pitchside.launch"), \
            open_session(BusConfig(connect=[router_endpoint])) as watcher:
        watcher.declare_subscriber(keys.topic_key("robot1", "robot_state"),
                                   lambda s: received.append(time.monotonic()))
        thread.start()
        try:
            wait_for(lambda: received, 30.0, what="the composed talker and echo at work")
            wait_for(lambda: "exited because its node BrokenAtStart failed" in caplog.text, 30.0,
                     what="the supervisor naming the failed node")
            first = good[0].pid
            assert first is not None
            os.kill(first, signal.SIGKILL)
            killed = time.monotonic()
            wait_for(lambda: received[-1] > killed + 0.05 and good[0].pid != first, 15.0,
                     what="the composed process back and its nodes talking")
            assert good[0].last_exit == "killed by SIGKILL"
        finally:
            launcher.stop()
            thread.join(20)
    assert f"exited with code {FAILED_NODE_EXIT + 1}" not in caplog.text  # said by name, not by number


def test_composed_arguments_take_only_parameters() -> None:
    with pytest.raises(ValueError, match="only --set"):
        robot_processes("robot1", [["hcm", "walking"]], [], extra={"hcm": ["--log-level", "DEBUG"]})
    processes = robot_processes("robot1", [["hcm", "walking"]], [], extra={"hcm": ["--set", "rate_hz=50"]})
    assert processes[0].argv[-2:] == ["--set", "hcm.rate_hz=50"]


def test_several_robots_share_a_process_each_with_its_own_nodes_parameters_and_loop(router_endpoint: str,
                                                                                      client: zenoh.Session) -> None:
    diagnostics: dict[str, dict[str, str]] = {}
    echoes: dict[str, int] = {"robot1": 0, "robot2": 0}

    def on_diagnostics(sample: zenoh.Sample) -> None:
        for status in schemas.decode(sample.payload.to_bytes(), "diagnostic_msgs/msg/DiagnosticArray").status:
            diagnostics[status.name] = {kv.key: kv.value for kv in status.values}

    def on_state(sample: zenoh.Sample) -> None:
        echoes[keys.split_topic_key(str(sample.key_expr))[0]] += 1

    client.declare_subscriber(keys.topic_key("*", "diagnostics"), on_diagnostics)
    client.declare_subscriber(keys.topic_key("*", "robot_state"), on_state)
    process = shared_process([RobotNodes("robot1", ["tests.proc_nodes:Talker", "tests.proc_nodes:Echo"],
                                         {"tests.proc_nodes:Talker": ["--set", "rate_hz=50"]}),
                              RobotNodes("robot2", ["tests.proc_nodes:Talker", "tests.proc_nodes:Echo"],
                                         {"tests.proc_nodes:Talker": ["--set", "rate_hz=20"]})],
                             [router_endpoint])
    proc = subprocess.Popen(process.argv, cwd=REPO)
    try:
        wait_for(lambda: {f"robot{i}/{n}" for i in (1, 2) for n in ("talker", "echo")} <= set(diagnostics), 30.0,
                 what="both robots' nodes' diagnostics")
        # each robot's echo answers its own talker, inside the process
        wait_for(lambda: min(echoes.values()) >= 10, 10.0, what="each robot's echo answering its talker")
        assert ParameterClient(client, "robot1").get("talker", "rate_hz") == 50.0
        assert ParameterClient(client, "robot2").get("talker", "rate_hz") == 20.0
        ParameterClient(client, "robot2").set("talker", {"rate_hz": 10.0})
        assert ParameterClient(client, "robot1").get("talker", "rate_hz") == 50.0  # one robot's, not the other's
        # on the wall clock the robots of the process share one loop (--one-loop): each tick's sensors wake it once
        wait_for(lambda: all(diagnostics[f"robot{i}/{n}"].get("loop_shared_by") == "4" for i in (1, 2)
                             for n in ("talker", "echo")), 10.0, what="the robots' nodes sharing one loop")
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(20) == 0, "a process of several robots stops cleanly on SIGTERM"


def test_a_process_of_several_robots_ends_naming_the_failed_node_with_its_robot(router_endpoint: str) -> None:
    process = shared_process([RobotNodes("robot1", ["tests.proc_nodes:Talker"]),
                              RobotNodes("robot2", ["tests.proc_nodes:Talker", "tests.proc_nodes:LeavesSoon"])],
                             [router_endpoint])
    assert process.name == "robot1+robot2"
    assert process.members == ["robot1/Talker", "robot2/Talker", "robot2/LeavesSoon"]
    out = subprocess.run(process.argv, cwd=REPO, capture_output=True, text=True, timeout=60)
    assert out.returncode == FAILED_NODE_EXIT + 2, out.stderr
    assert "robot2/leaves_soon stopped on its own" in out.stderr
    assert describe_exit(out.returncode, process.members) == "exited because its node robot2/LeavesSoon failed"
    broken = shared_process([RobotNodes("robot1", ["tests.proc_nodes:Talker"]),
                             RobotNodes("robot2", ["tests.proc_nodes:BrokenAtStart"])], [router_endpoint])
    out = subprocess.run(broken.argv, cwd=REPO, capture_output=True, text=True, timeout=60)
    assert out.returncode == FAILED_NODE_EXIT + 1 and "robot2/BrokenAtStart failed to start" in out.stderr


def test_the_robots_of_a_process_are_named_once_each() -> None:
    parser = robot_parser("compose", None)
    with pytest.raises(SystemExit, match="a robot is named twice"):
        parse_robots(parser, ["hcm", "--robot-id", "robot1", ROBOT_SEPARATOR, "walking", "--robot-id", "robot1"])
    with pytest.raises(SystemExit, match="a node is named twice"):
        parse_robots(parser, ["hcm", ROBOT_SEPARATOR, "hcm", "hcm", "--robot-id", "robot2"])
    _, robots = parse_robots(parser, ["hcm", "walking", "--set", "hcm.rate_hz=50", ROBOT_SEPARATOR, "hcm",
                                      "--robot-id", "robot2"])
    assert [(r.robot_id, r.nodes, r.set) for r in robots] == [("robot1", ["hcm", "walking"], ["hcm.rate_hz=50"]),
                                                              ("robot2", ["hcm"], [])]


class Sampler(Node):
    """A rate-limited subscription and a kept-latest one of the same topic."""

    name = "sampler"

    def setup(self) -> None:
        self.calls: list[float] = []
        self.limited = self.subscribe("joint_states", lambda _msg: self.calls.append(time.monotonic()), max_hz=20.0)
        self.newest = self.keep_latest("joint_states")


@pytest.mark.parametrize("outside", [False, True], ids=["composed", "other process"])
def test_rate_limited_and_latest_subscriptions_do_not_wake_the_node_for_every_message(
        session: zenoh.Session, bus: BusConfig, outside: bool) -> None:
    talker = Talker(bus=bus if outside else session, overrides={"rate_hz": 200.0})
    sampler = Sampler(bus=session)
    nodes = started(sampler, talker)
    try:
        wait_for(lambda: sampler.newest.count >= 400, 20.0, what="two seconds of 200 Hz")
        calls, taken = len(sampler.calls), sampler.newest.count
        assert 0 < calls <= taken / 200 * 20 * 1.2 + 2, (calls, taken)  # about 20 a second reached the handler
        assert sampler.limited.skipped >= taken - calls - 5
        newest = int(sampler.newest.message.position[0])
        assert newest >= talker.seq - 5, "the kept message is the newest"
    finally:
        for node in nodes:
            node.shutdown()
