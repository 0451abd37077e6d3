"""Bus health counters for diagnostics: who is silent, how often packets were lost or garbled."""

from __future__ import annotations

import time
from collections import deque
from typing import Any

# status-packet error bits, Protocol 1.0 (bit -> name)
P1_ERROR_BITS = {0x01: "input voltage", 0x02: "angle limit", 0x04: "overheating", 0x08: "range",
                 0x10: "checksum", 0x20: "overload", 0x40: "instruction"}
P2_ERROR_NUMBERS = {1: "result fail", 2: "instruction", 3: "crc", 4: "data range", 5: "data length",
                    6: "data limit", 7: "access"}


def describe_status_error(protocol: int, err: int) -> str:
    if protocol == 1:
        return ", ".join(name for bit, name in P1_ERROR_BITS.items() if err & bit) or "none"
    parts = ["hardware alert"] if err & 0x80 else []
    if err & 0x7F:
        parts.append(P2_ERROR_NUMBERS.get(err & 0x7F, f"error {err & 0x7F}"))
    return ", ".join(parts) or "none"


class BusHealth:
    """Counters the backend updates every cycle; `as_dict()` is what `DynamixelBackend.health()` returns."""

    def __init__(self, joint_names: list[str]) -> None:
        self.cycles = 0
        self.timeouts = 0  # broadcast reads that ended on the packet timeout
        self.corrupt_packets = 0  # bad checksum/CRC or wrong length
        self.tx_failures = 0
        self.rejected_goals = 0
        self.silent: list[str] = []
        self.missed = dict.fromkeys(joint_names, 0)  # cycles a joint had no fresh value
        self.servo_errors: dict[str, str] = {}
        self.last_error = ""
        self.events: deque[str] = deque(maxlen=20)
        self._cycle_times: deque[float] = deque(maxlen=200)

    def note(self, text: str) -> None:
        self.last_error = text
        self.events.append(f"{time.strftime('%H:%M:%S')} {text}")

    def end_cycle(self, missing: list[str], seconds: float) -> None:
        self.cycles += 1
        self._cycle_times.append(seconds)
        for name in missing:
            self.missed[name] += 1

    def went_silent(self, name: str, dxl_id: int) -> None:
        self.note(f"{name} (id {dxl_id}) silent; left out of bulk reads, re-probed periodically")

    def came_back(self, name: str, dxl_id: int) -> None:
        self.note(f"{name} (id {dxl_id}) answers again")

    def servo_error(self, name: str, protocol: int, err: int) -> None:
        text = describe_status_error(protocol, err)
        if self.servo_errors.get(name) != text:
            self.note(f"{name} reports {text}")
        self.servo_errors[name] = text

    def servo_ok(self, name: str) -> None:
        if self.servo_errors.pop(name, None) is not None:
            self.note(f"{name} error cleared")

    def as_dict(self) -> dict[str, Any]:
        times = sorted(self._cycle_times)
        mean_ms = 1000.0 * sum(times) / len(times) if times else 0.0
        text = "ok" if not self.silent else f"silent: {', '.join(self.silent)}"
        if self.corrupt_packets:
            text += f"; {self.corrupt_packets} corrupt packets"
        return {
            "ok": not self.silent,
            "text": text,
            "cycles": self.cycles,
            "silent": list(self.silent),
            "missed": {k: v for k, v in self.missed.items() if v},
            "timeouts": self.timeouts,
            "corrupt_packets": self.corrupt_packets,
            "tx_failures": self.tx_failures,
            "rejected_goals": self.rejected_goals,
            "servo_errors": dict(self.servo_errors),
            "read_ms_mean": round(mean_ms, 3),
            "read_ms_max": round(1000.0 * times[-1], 3) if times else 0.0,
            "last_error": self.last_error,
            "events": list(self.events),
        }
