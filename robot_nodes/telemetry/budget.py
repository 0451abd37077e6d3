"""The byte budget: a token bucket shared by priority (deficit round robin), so images never starve state."""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from schemas.topics import Priority
from wire.telemetry.datagram import HEADER_SIZE, TAG_SIZE, split

# Relative shares of the budget when every class has data; a class with nothing to send leaves its share
# to the others (work conserving). CRITICAL (robot_state, gamestate, overview) gets the most per round.
SHARES: dict[Priority, int] = {Priority.CRITICAL: 8, Priority.STATE: 4, Priority.PERCEPTION: 2, Priority.BULK: 1}
QUANTUM = 1400  # bytes of deficit a share unit earns per round


@dataclass(slots=True)
class Frame:
    """One message on its way out: its fragments, and how many are sent."""

    payload_size: int
    fragments: list[bytes]
    sent: int = 0
    frame_id: int = -1  # given by the sender with the first fragment, per wire stream

    @property
    def next_size(self) -> int:
        return HEADER_SIZE + len(self.fragments[self.sent]) + TAG_SIZE


@dataclass(slots=True)
class Stream:
    """A stream's outbox: the frame being sent and at most one waiting message (the newest wins)."""

    key: Any
    priority: Priority
    current: Frame | None = None
    waiting: Callable[[], bytes | None] | None = None
    frames_started: int = 0
    frames_sent: int = 0
    superseded: int = 0  # messages replaced by a newer one before they started
    bytes_sent: int = 0
    too_large: int = 0

    def head(self) -> Frame | None:
        """The frame to send from; starts the waiting message (prepares its payload lazily) if needed."""
        while self.current is None and self.waiting is not None:
            prepare, self.waiting = self.waiting, None
            payload = prepare()
            if payload is None:
                continue
            try:
                fragments = split(payload)
            except ValueError:  # larger than a frame may be: it cannot go, the stream goes on
                self.too_large += 1
                continue
            self.current = Frame(len(payload), fragments)
            self.frames_started += 1
        return self.current


@dataclass(slots=True)
class _Class:
    streams: deque[Stream] = field(default_factory=deque)
    deficit: int = 0


class ByteBudget:
    """Decides which datagram goes next and when, within ``bytes_per_s``.

    Messages are offered as a ``prepare()`` callable (encode/downscale happen only when the message is
    actually started, so superseded images cost no CPU). ``pump(send)`` sends what the token bucket allows:
    across priority classes by deficit round robin with ``SHARES``, within a class one datagram per stream
    in turn. Sequence numbers and nonces are given by ``send`` at the moment of sending, so a superseded
    message leaves no gap.
    """

    def __init__(self, bytes_per_s: float, burst_s: float = 0.25, clock: Callable[[], float] = time.monotonic) -> None:
        self.clock = clock
        self.bytes_per_s = float(bytes_per_s)
        self.burst_s = burst_s
        self.tokens = 0.0
        self._last = clock()
        self.streams: dict[Any, Stream] = {}
        self._classes: dict[Priority, _Class] = {p: _Class() for p in Priority}
        self._order = sorted(Priority)
        self._turn = 0  # index into _order of the class being served
        self._visiting = False  # the current class already got its quantum this visit

    @property
    def capacity(self) -> float:
        return max(self.bytes_per_s * self.burst_s, 2.0 * (HEADER_SIZE + TAG_SIZE + 1400))

    def set_rate(self, bytes_per_s: float) -> None:
        self._refill()
        self.bytes_per_s = float(bytes_per_s)

    def stream(self, key: Any, priority: Priority) -> Stream:
        s = self.streams.get(key)
        if s is None or s.priority != priority:
            if s is not None:
                self._classes[s.priority].streams.remove(s)
            s = self.streams[key] = s or Stream(key, priority)
            s.priority = priority
            self._classes[priority].streams.append(s)
        return s

    def remove(self, key: Any) -> None:
        s = self.streams.pop(key, None)
        if s is not None:
            self._classes[s.priority].streams.remove(s)

    def offer(self, key: Any, priority: Priority, prepare: Callable[[], bytes | None]) -> None:
        """Queue a message on a stream; a waiting, not yet started one is replaced (newest wins)."""
        s = self.stream(key, priority)
        if s.waiting is not None:
            s.superseded += 1
        s.waiting = prepare

    def _refill(self) -> None:
        now = self.clock()
        self.tokens = min(self.capacity, self.tokens + (now - self._last) * self.bytes_per_s)
        self._last = now

    def _class_head(self, cls: _Class) -> tuple[Stream, Frame] | None:
        for _ in range(len(cls.streams)):
            s = cls.streams[0]
            frame = s.head()
            if frame is not None:
                return s, frame
            cls.streams.rotate(-1)
        return None

    def pump(self, send: Callable[[Stream, Frame, int], int]) -> int:
        """Sends datagrams while the budget allows; ``send(stream, frame, index)`` returns bytes sent."""
        self._refill()
        sent_bytes = 0
        idle_classes = 0
        while idle_classes < len(self._order):
            cls = self._classes[self._order[self._turn]]
            head = self._class_head(cls)
            if head is None:
                cls.deficit = 0
                self._next_class()
                idle_classes += 1
                continue
            idle_classes = 0
            if not self._visiting:
                cls.deficit += SHARES[self._order[self._turn]] * QUANTUM
                self._visiting = True
            stream, frame = head
            size = frame.next_size
            if size > cls.deficit:
                self._next_class()
                continue
            if size > self.tokens:
                break  # resume this visit on the next pump
            index = frame.sent
            frame.sent += 1
            if frame.sent == len(frame.fragments):
                stream.current = None
                stream.frames_sent += 1
            n = send(stream, frame, index)
            stream.bytes_sent += n
            self.tokens -= n
            cls.deficit -= n
            sent_bytes += n
            cls.streams.rotate(-1)
        return sent_bytes

    def _next_class(self) -> None:
        self._turn = (self._turn + 1) % len(self._order)
        self._visiting = False

    def pending(self) -> bool:
        """Something waits to be sent (a message offered, or the rest of a started frame)."""
        return any(s.current is not None or s.waiting is not None for s in self.streams.values())

    def backlog(self) -> int:
        """Datagrams still to send of frames already started (for diagnostics)."""
        return sum(len(s.current.fragments) - s.current.sent for s in self.streams.values() if s.current)
