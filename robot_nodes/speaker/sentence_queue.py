"""The waiting sentences: three priority queues, FIFO within a priority, bounded by dropping the least important."""

from __future__ import annotations

import itertools
from collections import deque
from dataclasses import dataclass, field

LOW, MID, HIGH = 0, 1, 2
PRIORITY_NAMES = {LOW: "low", MID: "mid", HIGH: "high"}


@dataclass(frozen=True, slots=True)
class Utterance:
    """One sentence as it arrived; ``arrival`` orders sentences of equal priority."""

    text: str
    priority: int
    arrival: int = field(default=0, compare=False)

    @property
    def priority_name(self) -> str:
        return PRIORITY_NAMES[self.priority]


@dataclass(frozen=True, slots=True)
class Offer:
    """What became of an offered sentence: queued or not, and which sentence (if any) was dropped for room."""

    queued: bool
    dropped: Utterance | None = None
    reason: str = ""


class SpeechQueue:
    """Sentences waiting while another one is spoken.

    When full, the oldest sentence of the lowest waiting priority makes room, but only for a sentence at least as
    important; a sentence less important than everything waiting is refused instead.
    """

    def __init__(self, max_waiting: int = 10, drop_duplicates: bool = True) -> None:
        if max_waiting < 1:
            raise ValueError(f"max_waiting must be at least 1, got {max_waiting}")
        self.max_waiting = max_waiting
        self.drop_duplicates = drop_duplicates
        self._queues: dict[int, deque[Utterance]] = {p: deque() for p in (HIGH, MID, LOW)}
        self._arrivals = itertools.count()

    def offer(self, text: str, priority: int) -> Offer:
        if priority not in PRIORITY_NAMES:
            raise ValueError(f"priority {priority} is none of LOW_PRIORITY=0, MID_PRIORITY=1, HIGH_PRIORITY=2")
        if self.drop_duplicates and any(u.text == text for u in self._queues[priority]):
            return Offer(False, reason="the same sentence is already waiting")
        dropped = None
        if len(self) >= self.max_waiting:
            lowest = min(p for p, q in self._queues.items() if q)
            if lowest > priority:
                return Offer(False, reason=f"queue full of more important sentences ({self.max_waiting})")
            dropped = self._queues[lowest].popleft()
        self._queues[priority].append(Utterance(text, priority, next(self._arrivals)))
        return Offer(True, dropped)

    def pop(self) -> Utterance | None:
        """The next sentence to speak: the oldest of the highest waiting priority."""
        for p in (HIGH, MID, LOW):
            if self._queues[p]:
                return self._queues[p].popleft()
        return None

    def resize(self, max_waiting: int) -> list[Utterance]:
        """Shrinks or grows the bound; returns the sentences dropped to fit (least important, oldest first)."""
        if max_waiting < 1:
            raise ValueError(f"max_waiting must be at least 1, got {max_waiting}")
        self.max_waiting = max_waiting
        dropped = []
        while len(self) > max_waiting:
            lowest = min(p for p, q in self._queues.items() if q)
            dropped.append(self._queues[lowest].popleft())
        return dropped

    def clear(self) -> list[Utterance]:
        dropped = [u for p in (LOW, MID, HIGH) for u in self._queues[p]]
        for q in self._queues.values():
            q.clear()
        return dropped

    def waiting(self, priority: int) -> int:
        return len(self._queues[priority])

    def __len__(self) -> int:
        return sum(len(q) for q in self._queues.values())
