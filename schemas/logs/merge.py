"""One timeline from the laptop's match log and the robots' own logs: clocks aligned, duplicates dropped.

The laptop's log holds what telemetry carried (downsampled, lossy) on the laptop's clock; each robot's log holds what
the robot published at full rate on the robot's clock. A message telemetry carried is in both with the same CDR
bytes: those pairs give each robot's clock offset (the median of laptop time minus robot time: the telemetry
delay is small and the same for all) and are the duplicates, written once (the robot's copy, on the laptop's clock).
The result is one MCAP log with per-robot topics (``/<robot>/<topic>``) that replay, export and Foxglove open.
"""

from __future__ import annotations

import hashlib
import heapq
import statistics
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from schemas.logs.naming import BOOKMARK_TOPIC, LogError
from schemas.logs.reader import LogMessage, LogReader
from schemas.logs.series import LogSeriesReader
from schemas.logs.writer import LogWriter


@dataclass(slots=True)
class MergeReport:
    """What a merge did, per robot: its clock offset, messages taken from its log, duplicates dropped."""

    output: Path
    messages: int = 0
    offsets_s: dict[str, float] = field(default_factory=dict)
    from_robot: dict[str, int] = field(default_factory=dict)
    duplicates: dict[str, int] = field(default_factory=dict)
    unmatched: list[str] = field(default_factory=list)  # robots whose log shares no message with the laptop's


def _key(message: LogMessage) -> tuple[str, str, bytes]:
    return message.robot_id, message.topic, hashlib.blake2b(message.msg, digest_size=16).digest()


def _robot_messages(files: list[Path]) -> Iterator[LogMessage]:
    """Each file in time order, the files one after another (a robot's files do not overlap in time)."""
    for path in files:
        with LogReader(path) as reader:
            yield from (m for m in reader.messages(decode=False) if m.topic != BOOKMARK_TOPIC)


def clock_offsets(laptop_times: dict[tuple[str, str, bytes], int], robot_files: dict[str, list[Path]]
                  ) -> dict[str, int | None]:
    """Per robot: the median of (laptop log time - robot log time) over the messages both have, in ns."""
    offsets: dict[str, int | None] = {}
    for robot, files in robot_files.items():
        deltas = [laptop_times[k] - m.log_time_ns for m in _robot_messages(files) if (k := _key(m)) in laptop_times]
        offsets[robot] = int(statistics.median(deltas)) if deltas else None
    return offsets


def merge_logs(laptop_log: Path, robot_files: dict[str, list[Path]], output: Path) -> MergeReport:
    """Writes ``output``: the laptop's log (its series) and each robot's files, on the laptop's clock, each message
    once. LogError when a file does not open."""
    report = MergeReport(output)
    with LogSeriesReader(laptop_log) as laptop:
        laptop_times = {_key(m): m.log_time_ns for m in laptop.messages(decode=False) if m.topic != BOOKMARK_TOPIC}
        bookmarks = list(laptop.bookmarks)
    offsets = clock_offsets(laptop_times, robot_files)
    # what the robots' logs hold: the laptop's copies of these are the duplicates
    robot_keys = {_key(m) for files in robot_files.values() for m in _robot_messages(files)}
    streams: list[Iterator[tuple[int, int, LogMessage]]] = [_laptop(laptop_log, robot_keys, report)]
    for n, (robot, files) in enumerate(robot_files.items()):
        offset = offsets[robot]
        if offset is None:
            report.unmatched.append(robot)
            offset = 0  # no shared message: the robot's clock as it is (said in the report)
        report.offsets_s[robot] = offset / 1e9
        report.from_robot[robot] = report.duplicates[robot] = 0
        streams.append(_shifted(_robot_messages(files), offset, n + 1, report))
    try:
        with LogWriter(output) as writer:
            for log_time, _, message in heapq.merge(*streams, key=lambda item: (item[0], item[1])):
                writer.write(message.robot_id, message.topic, message.msg, message.typename, log_time_ns=log_time)
                report.messages += 1
            for bookmark in bookmarks:
                writer.add_bookmark(bookmark.name, log_time_ns=bookmark.log_time_ns, data=bookmark.data)
    except OSError as exc:
        raise LogError(f"merged log {output} not written: {exc}") from exc
    return report


def _shifted(messages: Iterator[LogMessage], offset_ns: int, order: int, report: MergeReport
             ) -> Iterator[tuple[int, int, LogMessage]]:
    local: set[tuple[str, str, bytes]] = set()
    for message in messages:
        key = _key(message)
        if key in local:  # the same message twice in a robot's files (a file pulled twice)
            continue
        local.add(key)
        report.from_robot[message.robot_id] = report.from_robot.get(message.robot_id, 0) + 1
        yield message.log_time_ns + offset_ns, order, message


def _laptop(laptop_log: Path, robot_keys: set[tuple[str, str, bytes]], report: MergeReport
            ) -> Iterator[tuple[int, int, LogMessage]]:
    with LogSeriesReader(laptop_log) as laptop:
        for message in laptop.messages(decode=False):
            if message.topic == BOOKMARK_TOPIC:
                continue
            if _key(message) in robot_keys:
                report.duplicates[message.robot_id] = report.duplicates.get(message.robot_id, 0) + 1
                continue
            yield message.log_time_ns, 0, message
