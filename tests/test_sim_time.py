"""Simulated time (robot_nodes/runtime/clock.py): nodes that follow a simulation's clock tick by it, over real
Zenoh sessions and with the real MuJoCo runner that sends it."""

from __future__ import annotations

import itertools
import math
import threading
import time

import pytest

import schemas
from robot_nodes.runtime import BusConfig, Node, open_session
from robot_nodes.runtime.clock import (
    LOCKSTEP,
    SIM_TIME_ENV,
    RobotSimClock,
    SimClock,
    clock_cdr,
    clock_seconds,
)
from robot_nodes.runtime.one_loop import NodesOnOneLoop
from robot_nodes.sim import SimRunner, SimWorld
from robot_nodes.sim.world_clock import ClockPublisher, SlowestTick, SlowestTicks, WorldClock
from tests.waiting import wait_for
from wire import keys


class Ticker(Node):
    name = "ticker"

    def setup(self) -> None:
        self.ticks: list[float] = []
        self.timer(lambda: self.ticks.append(self.now()), rate_hz=100.0, name="tick")

    def on_loop(self) -> float:
        """now() as the loop sees it, after everything queued before (the loop has caught up)."""
        seen: list[float] = []
        done = threading.Event()
        self.loop.call_soon(lambda: (seen.append(self.now()), done.set()))
        assert done.wait(5), "the node's loop did not answer"
        return seen[0]


def test_a_node_on_simulated_time_ticks_once_per_simulated_period_whatever_the_wall_clock_does(
        bus: BusConfig) -> None:
    clock = SimClock()
    node = Ticker(bus=bus, clock=clock).start()
    try:
        assert node.on_loop() == 0.0
        assert node.ticks == []  # the clock has not moved: a 100 Hz timer has not ticked, however long that took
        for step in range(1, 51):
            clock.advance(step * 0.01)
            wait_for(lambda step=step: len(node.ticks) >= step, timeout=5, what=f"tick {step} at {step * 0.01} s")
        assert node.on_loop() == pytest.approx(0.5)
        assert len(node.ticks) == 50
        assert node.ticks == pytest.approx([step * 0.01 for step in range(1, 51)])
        clock.advance(0.3)  # a clock that goes back (a late message) is not followed
        assert node.now() == pytest.approx(0.5)
        clock.advance(10.0)  # a jump: the timer skips what it missed rather than firing 950 times at once
        wait_for(lambda: len(node.ticks) > 50, timeout=5, what="the tick after the jump")
        assert node.on_loop() == 10.0
        assert 51 <= len(node.ticks) <= 52
    finally:
        node.shutdown()


class SlowTalker(Node):
    """At 100 Hz of its clock it works 20 ms of wall time, then tells the listener the time it ticked at."""

    name = "slow_talker"

    def setup(self) -> None:
        self.out = self.publisher("cmd_vel")
        self.timer(self.tick, rate_hz=100.0, name="tick")

    def tick(self) -> None:
        time.sleep(0.02)  # a loaded machine: the node takes longer than the world's step
        msg = schemas.make("geometry_msgs/msg/Twist")
        msg.linear.x = self.now()
        self.out.publish(msg)


class Listening(Node):
    name = "listening"

    def setup(self) -> None:
        self.heard: list[float] = []
        self.subscribe("cmd_vel", lambda m: self.heard.append(m.linear.x))


def test_a_lockstep_clock_moves_on_only_when_every_node_has_done_its_work_messages_included(bus: BusConfig) -> None:
    clock = SimClock(lockstep=True)
    session = open_session(bus)  # composed, as a simulated robot's nodes in a test: one session, the local bus
    talker = SlowTalker(bus=session, clock=clock).start()
    listener = Listening(bus=session, clock=clock).start()
    try:
        wait_for(lambda: talker.loop.thread is not None and listener.loop.thread is not None, 5, what="loops")
        started = time.monotonic()
        for step in range(1, 26):
            clock.advance(step * 0.01)
            # no waiting here: advance returned after the talker ticked and the listener handled what it said
            assert listener.heard[-1:] == [pytest.approx(step * 0.01)], f"step {step}: heard {listener.heard[-3:]}"
        assert time.monotonic() - started >= 25 * 0.02  # the clock waited for the slow node every step
        assert len(listener.heard) == 25 and clock.lockstep_timeouts == 0
    finally:
        listener.shutdown()
        talker.shutdown()
        session.close()
    clock.advance(1.0)  # nobody left to wait for: the clock moves on at once
    assert clock.lockstep_timeouts == 0


def test_a_lockstep_world_waits_for_the_robot_processes_and_lets_go_of_one_that_stops(
        bus: BusConfig, monkeypatch: pytest.MonkeyPatch) -> None:
    """The world's clock (WorldClock) and a robot's nodes in another Zenoh session, as in a match: the robot's
    process says on clock_done when its nodes are done with a time; at the next tick the world waits for that, then
    hands what they sent to the servos (goals_due) and only then tells the new time."""
    monkeypatch.setenv(SIM_TIME_ENV, LOCKSTEP)
    due: list[float | None] = []  # what the world's node had heard each time the goals went to the servos
    with open_session(bus) as world_session, open_session(bus) as robot_session:
        world = WorldClock(world_session, ["home1"], lockstep=True, done_timeout_s=0.5,
                           goals_due=lambda: due.append(listener.heard[-1] if listener.heard else None))
        listener = Listening(robot_id="home1", bus=world_session, clock=world.clock).start()  # the world's side
        talker = SlowTalker(robot_id="home1", bus=robot_session).start()  # 20 ms of work per 10 ms tick
        try:
            assert isinstance(talker.clock, RobotSimClock) and talker.clock.lockstep
            wait_for(lambda: world.tick(world.clock.now() + 0.01) or world.done.processes, timeout=10,
                     what="the robot's process answering the clock")  # type: ignore[union-attr]
            started, first = time.monotonic(), world.clock.now()
            for step in range(1, 26):
                t = first + step * 0.01
                world.tick(t)
                # no waiting here: the robot's nodes ticked at the tick before (while the world stepped to t), and
                # what they sent then is with the world's nodes; it went to the servos before t was told
                assert listener.heard[-1:] == [pytest.approx(t - 0.01)], f"step {step}: heard {listener.heard[-3:]}"
                assert due[-1] == pytest.approx(t - 0.01)
            assert time.monotonic() - started >= 25 * 0.02  # the world waited for the slow robot every tick
            assert world.done.timeouts == 0  # type: ignore[union-attr]
            # and says so: its slowest tick waited for the robot's process, by name (the cm730 node's diagnostics)
            slowest = world.slowest.so_far
            assert slowest.robots_ms >= 5.0 and slowest.robots_ms <= slowest.total_ms
            assert slowest.robots_last == ",".join(world.done.processes)  # type: ignore[union-attr]
            assert slowest.robots_last in slowest.describe()
            talker.shutdown()  # in the middle of its last tick's work, or after it
            world.tick(first + 0.3)
            world.tick(first + 0.31)  # a robot that stopped is waited for once, at most done_timeout_s...
            assert world.done.timeouts == 1 and world.done.processes == []  # type: ignore[union-attr]
            started = time.monotonic()
            world.tick(first + 0.32)  # ...and then no more
            assert time.monotonic() - started < 0.25
        finally:
            talker.shutdown()
            listener.shutdown()
            world.close()


def test_nodes_of_a_process_follow_their_robots_clock_topic_from_another_session(
        bus: BusConfig, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(SIM_TIME_ENV, "1")
    node = Ticker(robot_id="home1", bus=bus).start()
    other = Ticker(robot_id="away1", bus=bus).start()
    try:
        clock = node.clock
        assert isinstance(clock, RobotSimClock) and clock.robot == "home1"
        with open_session(bus) as world_session:
            publisher = ClockPublisher(world_session, "home1")
            wait_for(lambda: publisher.publish(clock_cdr(0.005)) or clock.now() == pytest.approx(0.005), timeout=10,
                     what="the first clock message")
            for step in range(1, 21):  # one at a time: a burst is one jump, and the timer would skip the rest
                publisher.publish(clock_cdr(step * 0.01))
                wait_for(lambda step=step: len(node.ticks) >= step, timeout=5, what=f"tick {step}")
            assert node.on_loop() == pytest.approx(0.2)
            assert len(node.ticks) == 20
            # ROS 2's /clock is the domain's: another robot of the simulation follows the same time
            wait_for(lambda: other.now() == pytest.approx(0.2), timeout=5, what="the other robot on the same /clock")
            world_session.put(keys.topic_key("home1", "clock"), b"\x00\x01\x00\x00 not a clock")
            wait_for(lambda: clock.bad_messages, timeout=5, what="the bad clock message counted")
            assert "rosgraph_msgs/msg/Clock" in clock.bad_messages[-1]
            assert clock.now() == pytest.approx(0.2)
            publisher.close()
    finally:
        node.shutdown()
        other.shutdown()


def test_robots_of_one_process_on_one_loop_follow_the_first_robots_clock_and_answer_once_a_tick(
        bus: BusConfig, monkeypatch: pytest.MonkeyPatch) -> None:
    """A simulated team's process (robot_nodes.compose --one-loop): its robots are in one world, so one clock drives
    their shared loop, and in lockstep the world waits for the process once per tick, not once per robot."""
    monkeypatch.setenv(SIM_TIME_ENV, LOCKSTEP)
    with open_session(bus) as world_session, open_session(bus) as team_session:
        world = WorldClock(world_session, ["home1", "home2"], lockstep=True, done_timeout_s=0.5)
        group = NodesOnOneLoop.of_process(team_session, "home1+home2", clock_of="home1")
        robots = [group.add(Ticker(robot_id=r, bus=team_session, loop=group.loop, clock=group.loop.clock))
                  for r in ("home1", "home2")]
        group.start()
        try:
            assert robots[1].clock is robots[0].clock and robots[0].clock.robot == "home1"  # type: ignore[attr-defined]
            wait_for(lambda: world.tick(world.clock.now() + 0.01) or world.done.processes, timeout=10,
                     what="the team's process answering the clock")  # type: ignore[union-attr]
            first = world.clock.now()
            for step in range(1, 21):
                world.tick(first + step * 0.01)
            world.tick(first + 0.21)  # waits until the process is done with the tick before
            assert [len([t for t in r.ticks if first + 0.005 < t < first + 0.205]) for r in robots] == [20, 20]
            assert world.done.timeouts == 0  # type: ignore[union-attr]
            assert [p.split("/")[0] for p in world.done.processes] == ["home1"]  # type: ignore[union-attr]
        finally:
            group.shutdown()
            world.close()


def test_the_clock_is_a_ros2_clock_message() -> None:
    import schemas

    for seconds in (0.0, 0.01, 12.345678901, 3600.5):
        cdr = clock_cdr(seconds)
        msg = schemas.decode(cdr, "rosgraph_msgs/msg/Clock")
        assert msg.clock.sec + msg.clock.nanosec * 1e-9 == pytest.approx(seconds, abs=1e-9)
        assert clock_seconds(cdr) == pytest.approx(seconds, abs=1e-9)
    with pytest.raises(schemas.SchemaError):
        clock_seconds(b"\x00\x01\x00\x00\x01")


def test_the_runner_steps_to_each_clock_tick_and_sends_every_one() -> None:
    world = SimWorld(n_robots=1)
    runner = SimRunner(world, real_time_factor=0.0)
    ticks: list[float] = []
    runner.tick_clock(0.01, ticks.append)
    runner.start()
    try:
        wait_for(lambda: len(ticks) >= 30, timeout=30, what="30 clock ticks")
    finally:
        runner.stop()
    got = ticks[:30]
    assert all(math.isclose(t / 0.01, round(t / 0.01), abs_tol=1e-6) for t in got), got
    assert [round(b - a, 9) for a, b in itertools.pairwise(got)] == [0.01] * 29
    assert runner.clock_errors == 0


def test_the_slowest_tick_is_kept_per_second_of_wall_time() -> None:
    ticks = SlowestTicks(window_s=1.0)
    t0 = time.monotonic()
    ticks.add(SlowestTick(5.0, 4.0, "a", 1.0), t0 + 0.1)
    ticks.add(SlowestTick(9.0, 8.0, "b", 1.0), t0 + 0.5)
    ticks.add(SlowestTick(3.0, 2.0, "a", 1.0), t0 + 0.7)
    assert ticks.last == SlowestTick() and ticks.so_far.robots_last == "b"
    ticks.add(SlowestTick(2.0, 1.0, "c", 1.0), t0 + 1.2)  # the next second: the one before is whole
    assert ticks.last.total_ms == 9.0 and ticks.last.robots_last == "b" and ticks.so_far.robots_last == "c"
