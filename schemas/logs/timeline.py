"""Where a log's real data begins: a recording that opened with old news (each stream's newest message, however old)
should not stretch its timeline back to that news; replay and the recordings listing both start where data does."""

from __future__ import annotations

import itertools

from schemas.logs.source import LogSource

# A gap this long between the messages of a log's opening snapshot (at most one per stream) means the messages
# before it are stale: a live stream repeats far more often, an event topic's old state is not this half's data.
STALE_GAP_S = 5.0


def data_start_ns(log: LogSource) -> int:
    """The log time of the first message after any stale opening messages (the log's start if there are none)."""
    times: list[int] = []
    seen: set[tuple[str, str]] = set()
    for item in log.messages(decode=False):
        stream = (item.robot_id, item.topic)
        if stream in seen:  # the opening snapshot has at most one message per stream: past it
            times.append(item.log_time_ns)
            break
        seen.add(stream)
        times.append(item.log_time_ns)
    if not times:
        return log.start_ns
    start = times[0]
    for before, after in itertools.pairwise(times):
        if after - before > STALE_GAP_S * 1e9:
            start = after
    return start
