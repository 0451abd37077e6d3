"""The simulated world's real-time factor as a demo or match run reports it, for the benches."""

from __future__ import annotations

import re
import time

import schemas
from robot_nodes.runtime import BusConfig, open_session
from schemas.std import DiagnosticArray
from wire import keys

ROUTER = re.compile(r"Zenoh router (tcp/[0-9.]+:\d+)")  # where a demo or match run says its router listens


class RealTimeFactor:
    """The world's real_time_factor reports (sim seconds per wall second over each 1 s, and over the last 10 s),
    read on the run's Zenoh bus: the first robot's cm730 node speaks for the world. Works in match mode too, where
    the dashboard hears only telemetry."""

    def __init__(self, endpoint: str, robot: str = "robot1") -> None:
        self.values: list[tuple[float, float]] = []  # (monotonic time, factor over 1 s)
        self.values_10s: list[tuple[float, float]] = []  # (monotonic time, factor over the last 10 s)
        self._session = open_session(BusConfig(connect=[endpoint]))
        self._sub = self._session.declare_subscriber(keys.topic_key(robot, "diagnostics"), self._on_sample)

    def _on_sample(self, sample: object) -> None:
        msg = schemas.decode(sample.payload.to_bytes(), DiagnosticArray)  # type: ignore[attr-defined]
        for status in msg.status:
            if status.name.endswith("/cm730"):
                for kv in status.values:
                    if kv.key == "real_time_factor":
                        self.values.append((time.monotonic(), float(kv.value)))
                    elif kv.key == "real_time_factor_10s":
                        self.values_10s.append((time.monotonic(), float(kv.value)))

    def between(self, t0: float, t1: float, values: list[tuple[float, float]] | None = None) -> list[float]:
        """The factors reported in (t0, t1]: of ``values`` (default: the 1 s ones)."""
        return [v for t, v in (self.values if values is None else values) if t0 < t <= t1]

    def close(self) -> None:
        self._sub.undeclare()
        self._session.close()
