"""The time a node lives in: the wall clock, or the simulation's (ROS 2's ``use_sim_time``).

A simulated robot's nodes follow the simulation's clock: the world publishes its time on ``clock``, ROS 2's
``/clock`` of every robot (rosgraph_msgs/Clock, every CLOCK_PERIOD_S of simulated time), and every node's timers,
``Node.now()`` and the age of what it received count in it. A world that falls behind real time (a busy machine)
then plays a slower match with the same physics: a 100 Hz walk still takes a step of 10 ms of simulated time, a
get-up still gets its 2 s. Before the first clock message a node's simulated time stands still at 0 and its timers
wait, as in ROS 2.

The rule for which clock: ``PITCHSIDE_SIM_TIME=1`` in a process's environment puts every node of it on its
robot's simulated clock; a node can also be given a clock. Header stamps stay on the wall clock (``schemas.stamp``),
so the dashboard's ages and the recordings of every robot and the team PC share one time line.

Lockstep across processes (``PITCHSIDE_SIM_TIME=lockstep``, what ``pitchside match`` sets for its robots): after
each clock message the process's nodes finish everything due up to that time (their motor goals sent), then the
process says so on ``clock_done``; the world (ClockDone) hands those goals to the servos at its next tick, once
every robot process it has heard from said so (WorldClock: a tick of delay, as on a real servo bus). A busy
machine then slows the match down instead of leaving the robots' control loops behind the physics, where they fell
over: a 2 v 2 match with two CPU burners beside it had 18 falls against 3 without them.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import zenoh

import schemas
from robot_nodes.runtime.local_bus import LocalBus
from schemas import stamps
from schemas.codec import Message, SchemaError
from wire import keys
from wire.ros2.attachment import AttachmentStamper
from wire.ros2.robots import next_node_id, publisher_entity

SIM_TIME_ENV = "PITCHSIDE_SIM_TIME"
LOCKSTEP = "lockstep"  # SIM_TIME_ENV's value for nodes the world waits for
CLOCK_TOPIC = "clock"
CLOCK_DONE_TOPIC = "clock_done"
CLOCK_PERIOD_S = 0.01  # simulated seconds between two clock messages: the fastest node timer (100 Hz) ticks on each
CLOCK_TYPE = "rosgraph_msgs/msg/Clock"


log = logging.getLogger(__name__)


def sim_time_wanted() -> bool:
    """Whether this process's nodes follow simulated time (PITCHSIDE_SIM_TIME)."""
    return os.environ.get(SIM_TIME_ENV, "") not in ("", "0")


def lockstep_wanted() -> bool:
    """Whether the world waits for this process's nodes (PITCHSIDE_SIM_TIME=lockstep)."""
    return os.environ.get(SIM_TIME_ENV, "") == LOCKSTEP


def clock_cdr(seconds: float) -> bytes:
    """The CDR of a rosgraph_msgs/Clock at ``seconds`` (the world encodes one a tick for all its robots)."""
    return schemas.encode(schemas.make(CLOCK_TYPE, clock=schemas.stamp(seconds)))


def clock_seconds(cdr: bytes) -> float:
    """The time a rosgraph_msgs/Clock's CDR carries; SchemaError for anything else."""
    return _seconds_of(schemas.decode(cdr, CLOCK_TYPE))


def _seconds_of(msg: Message) -> float:
    return stamps.seconds(msg.clock)  # type: ignore[attr-defined]


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
        if self._move(seconds) and self.lockstep:
            self.settle()

    def _move(self, seconds: float) -> bool:
        """The time moved to ``seconds`` and the loops whose next timer it passed woken; False: not forward."""
        if not seconds > self.time or not math.isfinite(seconds):
            return False
        self.time = seconds
        due = seconds + self.slack
        for waker in self._wakers:
            if waker.next_due <= due:
                waker.wake()
        return True

    def settle(self) -> None:
        """Until every loop is quiet up to now (messages that came since ``advance`` included); lockstep clocks."""
        until = self.time + self.slack
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

    def __init__(self, clock: RobotSimClock, robot: str, on_error: list[str]) -> None:
        self.clock = clock
        self.robot = robot
        self.topic = schemas.topic(CLOCK_TOPIC)
        self.errors = on_error

    def hand_over(self, key: str, msg: Message | SchemaError) -> None:
        if isinstance(msg, SchemaError):
            self._bad(msg)
        else:
            self.clock.receive(_seconds_of(msg))

    def hand_over_cdr(self, key: str, cdr: bytes) -> None:
        try:
            self.clock.receive(clock_seconds(cdr))
        except SchemaError as exc:
            self._bad(exc)

    def hand_over_local(self, robot: str, msg: Message, cdr: bytes | None) -> None:
        self.clock.receive(_seconds_of(msg))

    def _bad(self, error: SchemaError) -> None:
        """Someone else's bytes on the robot's clock key: kept (the newest ten) for a look, the clock stays."""
        self.errors.append(str(error))
        del self.errors[:-10]


class RobotSimClock(SimClock):
    """A robot's simulated time in a process of its nodes, taken from its ``clock`` topic (one per robot and
    Zenoh session, shared by the nodes that follow it; it leaves the bus with the last of them).

    lockstep: a clock message moves the time and wakes the loops whose timers it passed, without waiting for them
    on the thread that delivers messages (that would hold back the messages they wait for); the loop that goes quiet
    last (``settled``, or at once when none had anything to do) says so on ``clock_done``, stamped with the time and
    named by this process. No thread of its own: a follower thread cost two more thread switches a tick."""

    _of: dict[tuple[int, str], RobotSimClock] = {}
    _registry_lock = threading.Lock()

    def __init__(self, bus: LocalBus, robot: str, lockstep: bool = False) -> None:
        super().__init__(lockstep=lockstep)
        self.robot = robot
        self.bad_messages: list[str] = []
        self.users = 0
        self._bus = bus
        self._owed: float | None = None  # lockstep: the time whose clock_done is still to be said
        self._owed_lock = threading.Lock()
        if lockstep:
            bus.in_order = True  # the sensors of a time reach the loops before its clock message does
            self._done = bus.session.declare_publisher(keys.topic_key(robot, CLOCK_DONE_TOPIC))
            self._done_stamp = _stamper(bus.session, robot, "sim_clock", CLOCK_DONE_TOPIC)
            self._name = f"{robot}/{os.getpid()}/{id(self):x}"
        self._subscription = _ClockSubscription(self, robot, self.bad_messages)
        bus.add(self._subscription)  # type: ignore[arg-type]  # the subscription shape the bus asks of

    def receive(self, seconds: float) -> None:
        """A clock message (on the thread that delivers it)."""
        if not self.lockstep:
            self.advance(seconds)
            return
        with self._owed_lock:
            if not self._move(seconds):
                return
            self._owed = seconds
        self._say_done_if_quiet()

    def settled(self) -> None:
        """A loop is about to wait for work (or stopped: not waited for)."""
        if self._owed is not None:
            self._say_done_if_quiet()

    def _say_done_if_quiet(self) -> None:
        """clock_done for the owed time, once every loop is quiet up to it (said once, by whichever thread sees it
        first)."""
        with self._owed_lock:
            owed = self._owed
            if owed is None or not all(waker.quiet(owed + self.slack) for waker in self._wakers):
                return
            self._owed = None
            with contextlib.suppress(zenoh.ZError):  # the session closing
                self._done.put(schemas.encode(schemas.header(self._name, owed)), attachment=self._done_stamp.next())

    @classmethod
    def join(cls, bus: LocalBus, robot: str) -> RobotSimClock:
        with cls._registry_lock:
            key = (id(bus.session), robot)
            clock = cls._of.get(key)
            if clock is None or clock._bus is not bus:
                clock = cls._of[key] = RobotSimClock(bus, robot, lockstep=lockstep_wanted())
            clock.users += 1
            return clock

    def leave(self) -> None:
        with self._registry_lock:
            self.users -= 1
            key = (id(self._bus.session), self.robot)
            if self.users <= 0 and self._of.get(key) is self:
                del self._of[key]
                self._bus.remove(self._subscription)  # type: ignore[arg-type]
                if self.lockstep:
                    with self._owed_lock:
                        self._owed = None
                        self._done.undeclare()


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
        self._stamp = _stamper(session, robot, "sim_world", CLOCK_TOPIC)
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


def _stamper(session: zenoh.Session, robot: str, node: str, topic: str) -> AttachmentStamper:
    """The attachments of a clock publisher, as rmw_zenoh's publisher of that name would write them."""
    node_id = next_node_id()
    entity = publisher_entity(str(session.zid()), robot, node, topic, node_id, node_id + 1, keys.domain_id())
    return AttachmentStamper(entity.gid)
