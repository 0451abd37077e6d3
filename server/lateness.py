"""Telling live data from old data that arrives late: after a short link cut, TCP delivers what the robot sent
during the cut in one burst, seconds old. Shown as if current it would put robots where they were.

Robot and laptop clocks differ (nobody synchronises clocks at a venue), so a message's age cannot be read from
its stamp alone. Per robot and source, the smallest (arrival - sent) seen recently is the clocks' offset plus
the link's best latency; a message whose (arrival - sent) exceeds that by more than LATE_AFTER_S is late. If
every message stays late for longer than REBASE_AFTER_S, the robot's clock was set (NTP after boot) and the
offset is measured again rather than hiding live data.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

LATE_AFTER_S = 0.3  # a lost segment costs TCP about 0.2 s (its minimum retransmission timeout): still live
WINDOW_S = 30.0  # how far back the smallest delay is remembered (in buckets of BUCKET_S)
BUCKET_S = 5.0
REBASE_AFTER_S = 2.0


@dataclass(slots=True)
class ClockOffset:
    """The smallest (arrival - sent) of one robot's messages from one source over the last WINDOW_S."""

    buckets: deque[tuple[float, float]] = field(default_factory=deque)  # (bucket start, smallest delay in it)
    late_since: float | None = None

    def late_by(self, arrival: float, sent: float) -> float:
        """How much later than the best recent delay this message arrived (0 if it is as fresh as any)."""
        delay = arrival - sent
        if not self.buckets or arrival - self.buckets[-1][0] >= BUCKET_S:
            self.buckets.append((arrival, delay))
            while arrival - self.buckets[0][0] > WINDOW_S:
                self.buckets.popleft()
        elif delay < self.buckets[-1][1]:
            self.buckets[-1] = (self.buckets[-1][0], delay)
        excess = delay - min(d for _, d in self.buckets)
        if excess <= LATE_AFTER_S:
            self.late_since = None
            return excess
        if self.late_since is None:
            self.late_since = arrival
        elif arrival - self.late_since > REBASE_AFTER_S:
            self.buckets.clear()  # the robot's clock moved: start measuring again from this message
            self.buckets.append((arrival, delay))
            self.late_since = None
            return 0.0
        return excess


class Lateness:
    """ClockOffset per (robot, source)."""

    def __init__(self) -> None:
        self._offsets: dict[tuple[str, str], ClockOffset] = {}

    def late_by(self, robot: str, source: str, arrival: float, sent: float) -> float:
        offset = self._offsets.get((robot, source))
        if offset is None:
            offset = self._offsets[(robot, source)] = ClockOffset()
        return offset.late_by(arrival, sent)
