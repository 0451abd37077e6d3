"""The time a node lives in: the wall clock, or the simulation's (ROS 2's ``use_sim_time``).

A simulated robot's nodes follow the simulation's clock: the world publishes its time on the robot's ``clock``
topic (rosgraph_msgs/Clock, every CLOCK_PERIOD_S of simulated time) and every node's timers, ``Node.now()`` and the
age of what it received count in it. A world that falls behind real time (a busy machine) then plays a slower
match with the same physics: a 100 Hz walk still takes a step of 10 ms of simulated time, a get-up still gets its
2 s. Before the first clock message a node's simulated time stands still at 0 and its timers wait, as in ROS 2.

The rule for which clock: ``PITCHSIDE_SIM_TIME=1`` in a process's environment (``pitchside match`` sets it for the
robots) puts every node of it on its robot's simulated clock; a node can also be given a clock. Header stamps stay
on the wall clock (``schemas.stamp``), so the dashboard's ages and the recordings of every robot and the team PC
share one time line.
"""

from __future__ import annotations

import math
import os
import threading
import time
from typing import Protocol

import zenoh

import schemas
from robot_nodes.runtime.local_bus import LocalBus
from schemas.codec import Message, SchemaError
from wire import keys

SIM_TIME_ENV = "PITCHSIDE_SIM_TIME"
CLOCK_TOPIC = "clock"
CLOCK_PERIOD_S = 0.01  # simulated seconds between two clock messages: the fastest node timer (100 Hz) ticks on each
CLOCK_TYPE = "rosgraph_msgs/msg/Clock"


def sim_time_wanted() -> bool:
    """Whether this process's nodes follow simulated time (PITCHSIDE_SIM_TIME)."""
    return os.environ.get(SIM_TIME_ENV, "") not in ("", "0")


def clock_cdr(seconds: float) -> bytes:
    """The CDR of a rosgraph_msgs/Clock at ``seconds`` (the world encodes one a tick for all its robots)."""
    return schemas.encode(schemas.make(CLOCK_TYPE, clock=schemas.stamp(seconds)))


def clock_seconds(cdr: bytes) -> float:
    """The time a rosgraph_msgs/Clock's CDR carries; SchemaError for anything else."""
    return _seconds_of(schemas.decode(cdr, CLOCK_TYPE))


def _seconds_of(msg: Message) -> float:
    return float(msg.clock.sec) + float(msg.clock.nanosec) * 1e-9  # type: ignore[attr-defined]


class Waker(Protocol):
    """What a clock wakes: a node's loop waiting for its next timer (robot_nodes/runtime/loop.py)."""

    next_due: float

    def wake(self) -> None: ...

    def quiet(self, until: float) -> bool:
        """Nothing left to do up to ``until``: no timer due, no message waiting (a lockstep clock asks)."""
        ...


class Clock:
    """The wall clock (time.monotonic): what every node follows unless it simulates."""

    simulated = False
    lockstep = False
    slack = 0.0  # a timer due this much after now is due now

    def now(self) -> float:
        return time.monotonic()

    def wall_timeout(self, due: float) -> float | None:
        """Wall seconds a loop may sleep before ``due`` (None: until woken)."""
        return max(0.0, due - time.monotonic())

    def watch(self, waker: Waker) -> None:
        """The wall clock needs to wake no one: loops sleep until their timer."""

    def unwatch(self, waker: Waker) -> None:
        """See watch."""

    def settled(self) -> None:
        """A loop is about to wait for work (a lockstep clock looks again whether every loop is done)."""


WALL_CLOCK = Clock()


class SimClock(Clock):
    """Simulated time: it moves only when ``advance`` says so, and wakes the loops whose next timer it passes.

    ``advance`` runs on the world's physics thread or a Zenoh thread; loops read ``now`` from theirs. A loop
    publishes its next due time before it sleeps and the clock reads it after it moved: one of the two always sees
    the other's new value, so no timer is missed (robot_nodes/runtime/loop.py).

    lockstep: ``advance`` returns only when every loop that follows the clock has done all it had to up to the new
    time, messages the others sent it included (Gazebo's lockstep): the world waits for its robots' nodes, so a
    busy machine slows the simulation down instead of leaving the nodes behind it. For tests whose robots must act
    the same under any load. Only loops of this process count; ``lockstep_timeout_s`` (wall) bounds the wait for one
    that hangs, and each such wait is counted in ``lockstep_timeouts``."""

    simulated = True
    # a timer's due time adds its period up (0.01 + 0.01 + ...) and the clock's time is stepped up: the two miss
    # each other by a rounding error, and a timer would tick a whole clock period late
    slack = 1e-6

    def __init__(self, lockstep: bool = False, lockstep_timeout_s: float = 2.0) -> None:
        self.time = 0.0
        self.lockstep = lockstep
        self.lockstep_timeout_s = lockstep_timeout_s
        self.lockstep_timeouts = 0
        self._wakers: list[Waker] = []  # swapped, never changed in place: advance reads it without the lock
        self._lock = threading.Lock()
        self._settled = threading.Condition()

    def now(self) -> float:
        return self.time

    def wall_timeout(self, due: float) -> float | None:
        return 0.0 if due <= self.time + self.slack else None

    def advance(self, seconds: float) -> None:
        """The simulation's time is now ``seconds``; a clock never goes back (a late or repeated message)."""
        if not seconds > self.time or not math.isfinite(seconds):
            return
        self.time = seconds
        due = seconds + self.slack
        for waker in self._wakers:
            if waker.next_due <= due:
                waker.wake()
        if self.lockstep:
            self._wait_for_loops(due)

    def _wait_for_loops(self, until: float) -> None:
        deadline = time.monotonic() + self.lockstep_timeout_s
        with self._settled:
            while not all(waker.quiet(until) for waker in self._wakers):
                left = deadline - time.monotonic()
                if left <= 0:
                    self.lockstep_timeouts += 1
                    return
                self._settled.wait(left)

    def settled(self) -> None:
        if self.lockstep:
            with self._settled:
                self._settled.notify_all()

    def watch(self, waker: Waker) -> None:
        with self._lock:
            self._wakers = [*self._wakers, waker]

    def unwatch(self, waker: Waker) -> None:
        with self._lock:
            self._wakers = [w for w in self._wakers if w is not waker]
        self.settled()  # a stopped loop is not waited for


class _ClockSubscription:
    """The ``clock`` topic of one robot into a SimClock, from the world's process or another (the local bus's
    subscription shape; the clock is read on the thread that delivers it, it wakes no loop for nothing)."""

    def __init__(self, clock: SimClock, robot: str, on_error: list[str]) -> None:
        self.clock = clock
        self.robot = robot
        self.topic = schemas.topic(CLOCK_TOPIC)
        self.errors = on_error

    def hand_over(self, key: str, msg: Message | SchemaError) -> None:
        if isinstance(msg, SchemaError):
            self._bad(msg)
        else:
            self.clock.advance(_seconds_of(msg))

    def hand_over_cdr(self, key: str, cdr: bytes) -> None:
        try:
            self.clock.advance(clock_seconds(cdr))
        except SchemaError as exc:
            self._bad(exc)

    def hand_over_local(self, robot: str, msg: Message, cdr: bytes | None) -> None:
        self.clock.advance(_seconds_of(msg))

    def _bad(self, error: SchemaError) -> None:
        """Someone else's bytes on the robot's clock key: kept (the newest ten) for a look, the clock stays."""
        self.errors.append(str(error))
        del self.errors[:-10]


class RobotSimClock(SimClock):
    """A robot's simulated time in a process of its nodes, taken from its ``clock`` topic (one per robot and
    Zenoh session, shared by the nodes that follow it; it leaves the bus with the last of them)."""

    _of: dict[tuple[int, str], RobotSimClock] = {}
    _registry_lock = threading.Lock()

    def __init__(self, bus: LocalBus, robot: str) -> None:
        super().__init__()
        self.robot = robot
        self.bad_messages: list[str] = []
        self.users = 0
        self._bus = bus
        self._subscription = _ClockSubscription(self, robot, self.bad_messages)
        bus.add(self._subscription)  # type: ignore[arg-type]  # the subscription shape the bus asks of

    @classmethod
    def join(cls, bus: LocalBus, robot: str) -> RobotSimClock:
        with cls._registry_lock:
            key = (id(bus.session), robot)
            clock = cls._of.get(key)
            if clock is None or clock._bus is not bus:
                clock = cls._of[key] = RobotSimClock(bus, robot)
            clock.users += 1
            return clock

    def leave(self) -> None:
        with self._registry_lock:
            self.users -= 1
            key = (id(self._bus.session), self.robot)
            if self.users <= 0 and self._of.get(key) is self:
                del self._of[key]
                self._bus.remove(self._subscription)  # type: ignore[arg-type]


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
        self._local = LocalBus.join(session)

    def publish(self, cdr: bytes) -> None:
        for subscription in self._local.local_subscribers(self.robot, CLOCK_TOPIC):
            subscription.hand_over_cdr(self._key, cdr)
        self._pub.put(cdr)

    def close(self) -> None:
        self._pub.undeclare()
        self._local.leave()
