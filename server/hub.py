"""The one in-process hub: sources publish robot messages, subscribers (browsers, recorder) each get a bounded queue.

Everything here runs on the server's asyncio loop thread; sources on other threads hand their messages over
with ``Hub.publish_threadsafe`` (batched). A subscriber that does not read loses its oldest frames, so one
slow browser never stalls the others and memory stays bounded by ``maxlen`` per subscriber.
"""

from __future__ import annotations

import asyncio
import contextlib
import fnmatch
import logging
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import schemas
from server.lateness import LATE_AFTER_S, Lateness

log = logging.getLogger(__name__)

ANY = "*"
# Big messages get their own short queue per subscriber: memory stays bounded by a few images, not thousands.
BULK_TYPES = frozenset({"sensor_msgs/msg/CompressedImage", "sensor_msgs/msg/Image"})
BULK_MAXLEN = 4


@dataclass(slots=True, eq=False)
class HubMessage:
    """One robot message as a source saw it: decoded, or still CDR bytes (decoded on first use)."""

    robot: str
    topic: str
    typename: str
    stamp: float  # seconds since the epoch: the message's header stamp, else the time it was received
    data: Any  # a decoded message, or CDR bytes
    source: str  # "live", "telemetry", "replay", ...
    received: float = field(default_factory=time.monotonic)
    # when the robot sent it, by the robot's clock (header stamp, Zenoh timestamp, telemetry send time); None: not
    # known, or not live (replay). The hub holds back messages that arrive late (server.lateness).
    sent: float | None = None
    frame: str | bytes | None = None  # cache of the browser frame (server.protocol), built once for all clients
    decoded: Any = field(default=None, repr=False)  # cache of the message decoded from ``data``'s CDR

    @property
    def message(self) -> Any:
        """The decoded message (decoded once, on first use); schemas.SchemaError if the CDR does not decode."""
        if not isinstance(self.data, bytes | bytearray | memoryview):
            return self.data
        if self.decoded is None:
            self.decoded = schemas.decode(bytes(self.data), self.typename)
        return self.decoded

    @property
    def cdr(self) -> bytes:
        """The CDR as the source had it (a recording and Foxglove pass it on, never re-encoded)."""
        return bytes(self.data) if isinstance(self.data, bytes | bytearray | memoryview) else schemas.encode(self.data)


@dataclass(slots=True)
class Subscription:
    """What a subscriber wants: robot id or "*", topic (exact, "*" or a glob like "camera/*"), optional rate cap."""

    robot: str = ANY
    topic: str = ANY
    max_hz: float | None = None

    def matches(self, msg: HubMessage) -> bool:
        if self.robot != ANY and self.robot != msg.robot:
            return False
        if self.topic == ANY or self.topic == msg.topic:
            return True
        return "*" in self.topic and fnmatch.fnmatchcase(msg.topic, self.topic)


class Subscriber:
    """A bounded queue of hub messages for one consumer, rate-limited per (robot, topic) keeping the newest."""

    def __init__(self, hub: Hub, name: str, maxlen: int, include_late: bool = False) -> None:
        self.hub = hub
        self.name = name
        self.include_late = include_late  # a recorder keeps what arrived late; a browser shows only live data
        self.subscriptions: list[Subscription] = []
        self.delivered = 0
        self.dropped = 0  # lost to the bounded queue (slow reader)
        self.thinned = 0  # replaced by a newer message under a rate limit
        self._queue: deque[HubMessage] = deque(maxlen=maxlen)
        self._bulk: deque[HubMessage] = deque(maxlen=BULK_MAXLEN)
        self._next_ok: dict[tuple[str, str], float] = {}
        self._held: dict[tuple[str, str], HubMessage] = {}
        self._wakeup = asyncio.Event()
        self.closed = False

    # -- what the consumer wants ----------------------------------------------------------------------
    def subscribe(self, robot: str = ANY, topic: str = ANY, max_hz: float | None = None, replay_latest: bool = True
                  ) -> Subscription:
        """Adds (or updates) a subscription; the latest message of each matching stream is queued at once."""
        self.unsubscribe(robot, topic)
        sub = Subscription(robot, topic, max_hz if max_hz and max_hz > 0 else None)
        self.subscriptions.append(sub)
        if replay_latest:
            for msg in self.hub.latest_matching(sub):
                self._enqueue(msg)
        return sub

    def unsubscribe(self, robot: str = ANY, topic: str = ANY) -> None:
        self.subscriptions = [s for s in self.subscriptions if not (s.robot == robot and s.topic == topic)]

    def matching(self, msg: HubMessage) -> Subscription | None:
        for sub in self.subscriptions:
            if sub.matches(msg):
                return sub
        return None

    def discard_robot(self, robot: str) -> None:
        """Drops the queued messages of a robot that is gone for good, so none of it is shown after it left."""
        for queue in (self._queue, self._bulk):
            kept = [m for m in queue if m.robot != robot]
            if len(kept) != len(queue):
                queue.clear()
                queue.extend(kept)
        for key in [k for k in self._held if k[0] == robot]:
            del self._held[key]

    # -- the hub side ---------------------------------------------------------------------------------
    def offer(self, msg: HubMessage) -> None:
        sub = self.matching(msg)
        if sub is None:
            return
        if sub.max_hz is None:
            self._enqueue(msg)
            return
        key = (msg.robot, msg.topic)
        now = time.monotonic()
        next_ok = self._next_ok.get(key, 0.0)
        if now >= next_ok and key not in self._held:
            self._next_ok[key] = now + 1.0 / sub.max_hz
            self._enqueue(msg)
            return
        if key in self._held:
            self.thinned += 1
        else:
            asyncio.get_running_loop().call_later(max(next_ok - now, 0.0), self._release, key, sub.max_hz)
        self._held[key] = msg  # keep the newest until the stream may send again

    def _release(self, key: tuple[str, str], max_hz: float) -> None:
        msg = self._held.pop(key, None)
        if msg is not None and not self.closed:
            self._next_ok[key] = time.monotonic() + 1.0 / max_hz
            self._enqueue(msg)

    def _enqueue(self, msg: HubMessage) -> None:
        queue = self._bulk if msg.typename in BULK_TYPES else self._queue
        if len(queue) == queue.maxlen:
            self.dropped += 1
        queue.append(msg)
        self._wakeup.set()

    # -- the consumer side ----------------------------------------------------------------------------
    def __len__(self) -> int:
        return len(self._queue) + len(self._bulk)

    def drain(self, limit: int = 256) -> list[HubMessage]:
        """Up to ``limit`` queued messages, oldest first (images after the small messages)."""
        out: list[HubMessage] = []
        while self._queue and len(out) < limit:
            out.append(self._queue.popleft())
        while self._bulk and len(out) < limit:
            out.append(self._bulk.popleft())
        self.delivered += len(out)
        return out

    async def wait(self, timeout: float | None = None) -> bool:
        """True when messages are queued; False after ``timeout`` without any."""
        if self._queue or self._bulk:
            return True
        self._wakeup.clear()
        # asyncio.timeout, not wait_for: on Python 3.11 wait_for loses a cancellation that comes as the event is
        # set (the task goes on waiting, and a server's shutdown hangs on it)
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(timeout):
                await self._wakeup.wait()
        return bool(self._queue or self._bulk)

    def close(self) -> None:
        self.closed = True
        self.hub.unsubscribe(self)


@dataclass(slots=True)
class StreamStats:
    """How one (robot, topic) stream arrives: enough for link health in the team overview."""

    typename: str
    source: str
    count: int = 0
    late: int = 0  # arrived late (after a link cut): recorded, not shown as live
    last_received: float = 0.0  # monotonic
    rate_hz: float = 0.0
    _window_start: float = 0.0
    _window_count: int = 0

    def seen(self, now: float, source: str) -> None:
        self.count += 1
        self.last_received = now
        self.source = source
        if self._window_count == 0:
            self._window_start = now
        self._window_count += 1
        span = now - self._window_start
        if span >= 1.0:
            self.rate_hz = (self._window_count - 1) / span
            self._window_start = now
            self._window_count = 1
        elif self.rate_hz == 0.0 and span >= 0.3:  # a first estimate before the first full window
            self.rate_hz = (self._window_count - 1) / span

    def current_rate(self, now: float) -> float:
        """The measured rate, decaying to 0 once the stream is silent for longer than its period."""
        age = now - self.last_received
        if self.rate_hz <= 0 or age <= 2.0 / self.rate_hz:
            return self.rate_hz
        return 0.0 if age > 2.0 else min(self.rate_hz, 1.0 / age)


@dataclass(slots=True)
class RobotSeen:
    """A robot discovered from what arrived."""

    robot: str
    first_seen: float  # wall clock
    last_received: float = 0.0  # monotonic
    streams: dict[str, StreamStats] = field(default_factory=dict)


MAX_ROBOTS = 64  # robots the hub keeps apart (two teams of six, replays of earlier games, room to spare)
MAX_STREAMS = 4096  # (robot, topic) streams it remembers: a process inventing names cannot grow it further


class Hub:
    """Fans messages out to subscribers, remembers the latest message per (robot, topic) for late joiners.

    Its memory is bounded by design: at most MAX_ROBOTS robots and MAX_STREAMS streams are known (what comes beyond
    is refused and counted), each with its latest message and counters; each subscriber's queue has its maxlen."""

    def __init__(self, default_maxlen: int = 2000) -> None:
        self.default_maxlen = default_maxlen
        self.refused = 0  # messages of robots or streams beyond MAX_ROBOTS / MAX_STREAMS
        self.subscribers: list[Subscriber] = []
        self.latest: dict[tuple[str, str], HubMessage] = {}
        self.robots: dict[str, RobotSeen] = {}
        self.published = 0
        self.streams = 0  # known (robot, topic) streams, of every robot
        self.decode_errors = 0  # messages whose CDR did not decode when a subscriber needed them
        self.lateness = Lateness()  # per robot and source: which messages arrive late (server.lateness)
        self.loop: asyncio.AbstractEventLoop | None = None
        self._robot_listeners: list[Callable[[str], None]] = []
        self._gone_listeners: list[Callable[[str], None]] = []

    def bind(self, loop: asyncio.AbstractEventLoop) -> None:
        """The loop whose thread owns the hub; sources on other threads hand messages to it."""
        self.loop = loop

    def subscribe(self, name: str = "", maxlen: int | None = None, include_late: bool = False) -> Subscriber:
        sub = Subscriber(self, name or f"subscriber{len(self.subscribers)}", maxlen or self.default_maxlen,
                         include_late)
        self.subscribers.append(sub)
        return sub

    def unsubscribe(self, sub: Subscriber) -> None:
        if sub in self.subscribers:
            self.subscribers.remove(sub)

    def on_new_robot(self, listener: Callable[[str], None]) -> None:
        self._robot_listeners.append(listener)

    def on_robot_gone(self, listener: Callable[[str], None]) -> None:
        """listener(robot) when a robot is forgotten (a closed replay's): views drop what they show of it."""
        self._gone_listeners.append(listener)

    def publish(self, msg: HubMessage) -> None:
        """On the loop thread only. A message that arrives late is counted and recorded but not shown as live:
        not kept as the stream's latest, not sent to browsers."""
        now = msg.received
        late = msg.sent is not None and \
            self.lateness.late_by(msg.robot, msg.source, time.time(), msg.sent) > LATE_AFTER_S
        robot = self.robots.get(msg.robot)
        if robot is None:
            if len(self.robots) >= MAX_ROBOTS:
                self.refused += 1
                return
            robot = self.robots[msg.robot] = RobotSeen(msg.robot, time.time())
            for listener in self._robot_listeners:
                listener(msg.robot)
        stats = robot.streams.get(msg.topic)
        if stats is None:
            if self.streams >= MAX_STREAMS:
                self.refused += 1
                return
            stats = robot.streams[msg.topic] = StreamStats(msg.typename, msg.source)
            self.streams += 1
        self.published += 1
        if late:
            stats.late += 1
            for sub in self.subscribers:
                if sub.include_late:
                    sub.offer(msg)
            return
        robot.last_received = now
        stats.seen(now, msg.source)
        self.latest[(msg.robot, msg.topic)] = msg
        for sub in self.subscribers:
            sub.offer(msg)

    def publish_many(self, msgs: Iterable[HubMessage]) -> None:
        for msg in msgs:
            self.publish(msg)

    def publish_threadsafe(self, msgs: list[HubMessage]) -> None:
        """From a source's thread: one loop wake-up per batch."""
        if self.loop is None:
            raise RuntimeError("hub is not bound to an event loop yet (Hub.bind)")
        self.loop.call_soon_threadsafe(self.publish_many, msgs)

    def forget(self, robot: str) -> None:
        """A robot that is gone for good (a closed replay): out of the robots list and the latest messages."""
        gone = self.robots.pop(robot, None)
        if gone is not None:
            self.streams -= len(gone.streams)
        for key in [k for k in self.latest if k[0] == robot]:
            del self.latest[key]
        for sub in self.subscribers:
            if not sub.include_late:  # a recorder keeps what it was handed
                sub.discard_robot(robot)
        for listener in self._gone_listeners:
            try:
                listener(robot)
            except Exception:  # one view failing must not keep the robot in the others
                log.exception("a view did not let go of %s", robot)

    def latest_matching(self, sub: Subscription) -> list[HubMessage]:
        return [m for m in self.latest.values() if sub.matches(m)]
