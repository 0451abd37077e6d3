"""Several nodes on one loop thread (robot_nodes/runtime/one_loop.py): each keeps its name, parameters, timers,
diagnostics and errors; one node leaving does not stop the others."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest
import zenoh

import schemas
from robot_nodes.runtime import BusConfig, GoalStatus, Node, ParameterClient, open_session
from robot_nodes.runtime.one_loop import NodesOnOneLoop
from tests.proc_nodes import Echo, Talker
from tests.test_runtime import GOAL, Player
from tests.waiting import wait_for
from wire import keys
from wire.actions import ClientGoal


class Failing(Talker):
    """A talker whose tick raises after publishing, every time."""

    name = "failing"

    def tick(self) -> None:
        super().tick()
        raise RuntimeError("broken tick")


@pytest.fixture
def session(bus: BusConfig) -> Iterator[zenoh.Session]:
    with open_session(bus) as shared:
        yield shared


def test_nodes_on_one_loop_keep_their_own_timers_parameters_diagnostics_and_errors(session: zenoh.Session,
                                                                                   client: zenoh.Session) -> None:
    statuses: dict[str, dict[str, str]] = {}

    def on_diagnostics(sample: zenoh.Sample) -> None:
        for status in schemas.decode(sample.payload.to_bytes(), "diagnostic_msgs/msg/DiagnosticArray").status:
            statuses[status.name] = {kv.key: kv.value for kv in status.values}

    client.declare_subscriber(keys.topic_key("*", "diagnostics"), on_diagnostics)
    group = NodesOnOneLoop("test")
    echo = group.add(Echo(robot_id="robot1", bus=session, loop=group.loop))
    talker = group.add(Talker(robot_id="robot1", bus=session, loop=group.loop, overrides={"rate_hz": 100.0}))
    failing = group.add(Failing(robot_id="robot2", bus=session, loop=group.loop, overrides={"rate_hz": 50.0}))
    assert echo.loop is talker.loop is failing.loop is group.loop
    group.start()
    try:
        # the talker's messages reach the echo on the same loop; the failing node's errors are its own
        wait_for(lambda: echo.received >= 50, 10.0, what="the echo hearing the talker on the shared loop")
        wait_for(lambda: failing.errors >= 10, 10.0, what="the failing node's errors")
        assert talker.errors == 0 and echo.errors == 0, (talker.last_error, echo.last_error)
        assert "broken tick" in failing.last_error
        # parameters stay per node, and a change reaches the right node's timer
        params = ParameterClient(client, "robot1")
        wait_for(lambda: {"talker", "echo"} <= set(params.nodes()), 10.0, what="both robot1 nodes' parameters")
        params.set("talker", {"rate_hz": 20.0})
        assert ParameterClient(client, "robot2").get("failing", "rate_hz") == 50.0
        wait_for(lambda: talker.tick_timer.period_s == pytest.approx(0.05), 5.0, what="the talker's new rate")
        # each node reports under its own name, and says whom it shares the loop with
        wait_for(lambda: {"robot1/talker", "robot1/echo", "robot2/failing"} <= set(statuses)
                 and statuses["robot1/talker"].get("loop_shared_by") == "3", 10.0, what="three nodes' diagnostics")
        assert statuses["robot2/failing"]["errors"] != "0" and statuses["robot1/echo"]["errors"] == "0"
        longest = float(statuses["robot1/echo"]["loop_longest_call_ms"].split()[0])
        assert 0.0 < longest < 1000.0

        # one node leaves: its timer stops, the others go on
        failing.shutdown()
        ticks = failing.seq
        heard = echo.received
        wait_for(lambda: echo.received >= heard + 20, 10.0, what="the echo going on after another node left")
        assert failing.seq == ticks, "the node that left does not tick any more"
    finally:
        group.shutdown()
    assert group.loop.stopped and all(node._closed for node in (echo, talker, failing))


def test_a_node_on_a_shared_loop_is_run_by_its_group_only(session: zenoh.Session) -> None:
    group = NodesOnOneLoop("test")
    talker = group.add(Talker(bus=session, loop=group.loop))
    with pytest.raises(RuntimeError, match="shares a loop"):
        talker.start()
    other = NodesOnOneLoop("other")
    with pytest.raises(ValueError, match="this group's loop"):
        other.add(talker)
    group.shutdown()


class Director(Node):
    """Sends animation goals and cancels them from its loop, as the HCM, the kick and the behaviour do."""

    name = "director"

    def setup(self) -> None:
        self.client = self.action_client("animation")
        self.answers: list[bool] = []
        self.cancel_took_s: list[float] = []

    def cancel_soon(self, goal: ClientGoal, blocking: bool) -> None:
        def cancel() -> None:
            started = time.monotonic()
            if blocking:
                self.answers.append(goal.cancel(timeout=0.2))
            else:
                goal.request_cancel(self.answers.append)
            self.cancel_took_s.append(time.monotonic() - started)

        self.loop.call_soon(cancel)


def test_a_goal_served_on_the_same_loop_is_canceled_without_holding_the_loop(session: zenoh.Session) -> None:
    """The animation server and its client on one loop (a composed robot on simulated time, or a simulated team on
    one loop): a blocking cancel waits out its whole timeout, as the server answers only once the loop is free, and
    the loop (every node on it) stands that long; request_cancel returns at once and the answer comes on the loop."""
    group = NodesOnOneLoop("test")
    player = group.add(Player(robot_id="robot1", bus=session, loop=group.loop))
    director = group.add(Director(robot_id="robot1", bus=session, loop=group.loop))
    group.start()
    try:
        for blocking in (True, False):
            goal = director.client.send_goal(schemas.make(GOAL, animation="long"))
            assert goal.wait_accepted(5)
            wait_for(lambda g=goal: player.active is not None and player.active.id == g.id, 5.0,
                     what="the player playing the goal")
            director.cancel_soon(goal, blocking)
            status, _ = goal.wait_result(5)
            assert status == GoalStatus.CANCELED
        wait_for(lambda: len(director.answers) == 2, 5.0, what="both cancels answered")
        blocked, requested = director.cancel_took_s
        assert blocked >= 0.19 and director.answers[0] is False  # the server could not answer in time
        assert requested < 0.1 and director.answers[1] is True  # microseconds; a busy machine may add a switch
    finally:
        group.shutdown()
