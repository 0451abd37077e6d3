"""Time stamps and headers of messages: the one conversion from seconds since the epoch to builtin_interfaces/Time."""

from __future__ import annotations

import time

from schemas.std import Header, Time

NS = 1_000_000_000


def stamp(t: float | None = None) -> Time:
    """builtin_interfaces/Time of ``t`` (seconds since the epoch), or of now."""
    ns = time.time_ns() if t is None else int(t * 1e9)
    return Time(sec=ns // NS, nanosec=ns % NS)


def header(frame_id: str = "", t: float | None = None) -> Header:
    """std_msgs/Header stamped ``t`` (or now) in ``frame_id``."""
    return Header(stamp=stamp(t), frame_id=frame_id)


def seconds(time_msg: Time) -> float:
    """A builtin_interfaces/Time back in seconds since the epoch."""
    return float(time_msg.sec) + float(time_msg.nanosec) * 1e-9
