"""The simulation's side of the clock (robot_nodes/runtime/clock.py is the nodes' side): every robot's ``clock``
topic published from the world's time, and in lockstep the waits that keep every robot's nodes in step with the
physics (``clock_done``). Nodes never see this module; they follow a ``Clock``."""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import zenoh

import schemas
from robot_nodes.runtime.clock import CLOCK_DONE_TOPIC, CLOCK_TOPIC, SimClock, clock_cdr, stamper
from robot_nodes.runtime.local_bus import LocalBus
from schemas import stamps
from schemas.codec import SchemaError
from wire import keys

log = logging.getLogger(__name__)


class ClockPublisher:
    """The world's side: a robot's ``clock`` topic, put as CDR encoded once a tick for every robot (clock_cdr);
    nodes of the world's own process that follow it get it through the local bus, as any topic."""

    def __init__(self, session: zenoh.Session, robot: str) -> None:
        self.robot = robot
        topic = schemas.topic(CLOCK_TOPIC)
        encoding = zenoh.Encoding("application/cdr").with_schema(topic.type)
        self._key = keys.topic_key(robot, CLOCK_TOPIC)
        self._pub = session.declare_publisher(self._key, encoding=encoding,
                                              allowed_destination=zenoh.Locality.REMOTE)
        self._stamp = stamper(session, robot, "sim_world", CLOCK_TOPIC)
        self._local = LocalBus.join(session)

    def publish(self, cdr: bytes, remote: bool = True) -> None:
        """remote: also put it on the bus (a world of several robots puts ROS 2's one /clock once a tick)."""
        for subscription in self._local.local_subscribers(self.robot, CLOCK_TOPIC):
            subscription.hand_over_cdr(self._key, cdr)
        if remote:
            self._pub.put(cdr, attachment=self._stamp.next())

    def close(self) -> None:
        self._pub.undeclare()
        self._local.leave()


@dataclass(frozen=True)
class SlowestTick:
    """The longest clock tick of a second of wall time in lockstep, and what it waited for: the robots' processes
    (the last of them to say it was done) or the world's own cm730 nodes sending the sensors."""

    total_ms: float = 0.0
    robots_ms: float = 0.0
    robots_last: str = ""  # the processes the world still waited for when it had waited longest
    sensors_ms: float = 0.0

    def describe(self) -> str:
        return (f"{self.total_ms:.0f} ms: robots {self.robots_ms:.0f} ms (last {self.robots_last or '-'}), "
                f"own sensors {self.sensors_ms:.0f} ms")


class SlowestTicks:
    """SlowestTick per second of wall time: ``last`` is the whole second before, so every reader sees the same."""

    def __init__(self, window_s: float = 1.0) -> None:
        self.window_s = window_s
        self.last = SlowestTick()
        self._now = SlowestTick()
        self._window_ends = time.monotonic() + window_s

    @property
    def so_far(self) -> SlowestTick:
        """The slowest tick of the second in progress."""
        return self._now

    def add(self, tick: SlowestTick, now: float) -> None:
        if now >= self._window_ends:
            self.last, self._now = self._now, SlowestTick()
            self._window_ends = now + self.window_s
        if tick.total_ms > self._now.total_ms:
            self._now = tick


class ClockDone:
    """The world's side of lockstep: which processes of the robots' nodes are done with which simulated time
    (``clock_done``). A process is waited for from its first message on; one that does not answer within
    ``timeout_s`` (wall) is no longer waited for, until it answers again (a robot that stopped or restarts)."""

    def __init__(self, session: zenoh.Session, robots: list[str], timeout_s: float = 1.0) -> None:
        self.timeout_s = timeout_s
        self.timeouts = 0  # waits given up
        self._done: dict[str, float] = {}  # process -> the newest time it is done with
        self._changed = threading.Condition()
        # on Zenoh's network thread: after every sample the process sent before (its motor goals; LocalBus.in_order)
        self._subscribers = [session.declare_subscriber(keys.topic_key(robot, CLOCK_DONE_TOPIC),
                                                        zenoh.handlers.Callback(self._on_done, indirect=False))
                             for robot in robots]

    def _on_done(self, sample: zenoh.Sample) -> None:
        try:
            msg = schemas.decode(sample.payload.to_bytes(), "std_msgs/msg/Header")
        except SchemaError:
            return  # not a process of robot nodes: nothing to wait for
        seconds = stamps.seconds(msg.stamp)
        process = str(msg.frame_id)
        with self._changed:
            if process not in self._done:
                log.info("lockstep: the simulation waits for %s's nodes from now on", process)
            self._done[process] = max(seconds, self._done.get(process, -math.inf))
            self._changed.notify_all()

    @property
    def processes(self) -> list[str]:
        """The processes waited for."""
        with self._changed:
            return sorted(self._done)

    def wait(self, seconds: float) -> list[str]:
        """Until every process waited for is done with ``seconds``; returns the last ones it waited for."""
        deadline = time.monotonic() + self.timeout_s
        waited_for: list[str] = []
        with self._changed:
            while late := [p for p, t in self._done.items() if t < seconds - 1e-6]:
                waited_for = late
                left = deadline - time.monotonic()
                if left <= 0:
                    self.timeouts += 1
                    for process in late:
                        del self._done[process]
                    log.warning("lockstep: %s not done with %.2f s of simulated time after %.1f s; not waited for "
                                "until they answer again", ", ".join(late), seconds, self.timeout_s)
                    return waited_for
                self._changed.wait(left)
        return waited_for

    def close(self) -> None:
        for subscriber in self._subscribers:
            subscriber.undeclare()


class WorldClock:
    """The simulation's side of the clock, ticked by the world's runner every CLOCK_PERIOD_S of simulated time:
    the clock its own nodes follow (``clock``), every robot's ``clock`` topic, and in lockstep the waits that keep
    every node in step with the physics.

    Lockstep with a tick of delay, as a servo bus at 100 Hz has it (the goals computed from one reading are written
    with the next): the robots work on the sensors of time t while the physics steps from t to t + CLOCK_PERIOD_S,
    and their motor goals reach the servos at the next tick. The world waits for them only then, so stepping and the
    robots' work share the CPU instead of taking turns (a 4 v 4 match, 60 s of play, two runs each: the world's
    real-time factor 0.85 and 0.81 taking turns, 0.89 and 0.96 sharing). ``goals_due`` (the world's
    ``release_changes``) hands the goals of the last tick to the servos, all of them and at the same step whatever
    the moment each came in, so a match plays the same on a busy machine and an idle one."""

    def __init__(self, session: zenoh.Session, robots: list[str], lockstep: bool = False,
                 done_timeout_s: float = 1.0, goals_due: Callable[[], None] | None = None) -> None:
        self.clock = SimClock(lockstep=lockstep)
        self._publishers = [ClockPublisher(session, robot) for robot in robots]
        self._bus = LocalBus.join(session)
        if lockstep:
            self._bus.in_order = True  # before the world's nodes subscribe
        self.done = ClockDone(session, robots, done_timeout_s) if lockstep else None
        self._goals_due = goals_due
        self._sent: float | None = None  # the time of the last tick the robots were told
        self.slowest = SlowestTicks()  # in lockstep: what held the physics (the cm730 node's diagnostics)

    def tick(self, seconds: float) -> None:
        started = time.monotonic()
        waited_for: list[str] = []
        if self.done is not None and self._sent is not None:
            waited_for = self.done.wait(self._sent)  # the robots' nodes are done with the last tick: goals sent...
            self.clock.settle()  # ...and, sent before they said so, arrived here and are with the world's nodes
            if self._goals_due is not None:
                self._goals_due()  # ...which hand them to the servos for the step from now on
        robots_done = time.monotonic()
        self.clock.advance(seconds)  # lockstep: returns when this process's nodes have sent the sensors of this time
        cdr = clock_cdr(seconds)
        for index, publisher in enumerate(self._publishers):
            publisher.publish(cdr, remote=index == 0)  # /clock is every robot's: on the bus once
        self._sent = seconds
        if self.done is not None:
            now = time.monotonic()
            self.slowest.add(SlowestTick((now - started) * 1e3, (robots_done - started) * 1e3, ",".join(waited_for),
                                         (now - robots_done) * 1e3), now)

    def close(self) -> None:
        for publisher in self._publishers:
            publisher.close()
        if self.done is not None:
            self.done.close()
        self._bus.leave()
