"""LogSeriesReader: the files of a size-rotated log (``game.mcap``, ``game_001.mcap`` ...) read as one."""

from __future__ import annotations

import dataclasses
import heapq
from collections.abc import Callable, Collection, Iterator
from pathlib import Path
from types import TracebackType

from schemas.logs.naming import LogError, log_series
from schemas.logs.reader import Bookmark, ChannelInfo, LogMessage, LogReader


class LogSeriesReader:
    """Same questions as LogReader, answered over every file of the series; each file seeks with
    its own index and their messages are merged by log time."""

    def __init__(self, path: str | Path, *, on_progress: Callable[[float], None] | None = None) -> None:
        files = log_series(path)
        if not files:
            raise LogError(f"no log files at {path}")
        self.paths = files
        self.readers: list[LogReader] = []
        try:
            for k, file in enumerate(files):
                progress = None if on_progress is None else _scaled(on_progress, k, len(files))
                self.readers.append(LogReader(file, on_progress=progress))
        except LogError:
            self.close()
            raise

    @property
    def warnings(self) -> list[str]:
        return [w for r in self.readers for w in r.warnings]

    @property
    def channels(self) -> list[ChannelInfo]:
        """One entry per (robot, topic, type), message counts summed over the files."""
        merged: dict[tuple[str, str, str], ChannelInfo] = {}
        for reader in self.readers:
            for info in reader.channels:
                key = (info.robot_id, info.topic, info.typename)
                seen = merged.get(key)
                merged[key] = info if seen is None else dataclasses.replace(
                    seen, message_count=seen.message_count + info.message_count)
        return sorted(merged.values(), key=lambda c: (c.robot_id, c.topic, c.typename))

    @property
    def topics(self) -> dict[str, str]:
        return {c.topic: c.typename for c in self.channels}

    @property
    def robots(self) -> list[str]:
        return sorted({c.robot_id for c in self.channels})

    @property
    def message_count(self) -> int:
        return sum(r.message_count for r in self.readers)

    @property
    def start_ns(self) -> int:
        starts = [r.start_ns for r in self.readers if r.message_count]
        return min(starts) if starts else 0

    @property
    def end_ns(self) -> int:
        ends = [r.end_ns for r in self.readers if r.message_count]
        return max(ends) if ends else 0

    @property
    def duration(self) -> float:
        return (self.end_ns - self.start_ns) / 1e9

    def messages(
        self,
        start_ns: int | None = None,
        end_ns: int | None = None,
        topics: Collection[str] | None = None,
        robots: Collection[str] | None = None,
        decode: bool = True,
    ) -> Iterator[LogMessage]:
        """As LogReader.messages, over all files, in log-time order."""
        streams = [r.messages(start_ns, end_ns, topics, robots, decode) for r in self.readers
                   if r.message_count and (start_ns is None or r.end_ns >= start_ns)
                   and (end_ns is None or r.start_ns < end_ns)]
        return heapq.merge(*streams, key=lambda m: m.log_time_ns)

    @property
    def bookmarks(self) -> list[Bookmark]:
        marks = [b for r in self.readers for b in r.bookmarks]
        return sorted(marks, key=lambda m: (m.log_time_ns, m.name))

    def close(self) -> None:
        for reader in self.readers:
            reader.close()

    def __enter__(self) -> LogSeriesReader:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


def _scaled(on_progress: Callable[[float], None], k: int, n: int) -> Callable[[float], None]:
    """Progress of file k of n as a fraction of the whole series."""
    return lambda fraction: on_progress((k + fraction) / n)
