"""Search patterns: the points a searching head visits in turn, sweeping rows from side to side within its limits."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class SearchPattern:
    """Rows of tilt, each swept across ``[-pan, pan]``, alternating direction: a closed loop of (pan, tilt) points."""

    points: tuple[tuple[float, float], ...]

    @classmethod
    def sweep(cls, pan: float, tilts: tuple[float, ...]) -> SearchPattern:
        points: list[tuple[float, float]] = []
        for i, tilt in enumerate(tilts):
            ends = (pan, -pan) if i % 2 == 0 else (-pan, pan)
            points += [(ends[0], tilt), (ends[1], tilt)]
        return cls(tuple(points))

    def nearest(self, pan: float, tilt: float) -> int:
        """The point to start at from the head's present position: the closest one."""
        return min(range(len(self.points)), key=lambda i: math.hypot(self.points[i][0] - pan,
                                                                       self.points[i][1] - tilt))

    def next(self, index: int) -> int:
        return (index + 1) % len(self.points)
