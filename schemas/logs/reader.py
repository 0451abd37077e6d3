"""LogReader: pitchside logs and third-party ROS 2 MCAP bags, indexed seeking, crash-cut files."""

from __future__ import annotations

import functools
import heapq
import json
import logging
import threading
from collections.abc import Callable, Collection, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, NamedTuple

from mcap.reader import SeekingReader
from mcap.records import Channel, ChunkIndex, Message, Metadata, Schema
from mcap.summary import Summary

from schemas.logs.decoding import Decoder, UndecodableChannel, make_decoder
from schemas.logs.naming import (
    BOOKMARK_METADATA_NAME,
    BOOKMARK_TOPIC,
    LogError,
    full_typename,
    split_channel,
)
from schemas.logs.records import MAGIC, Recovery, chunk_messages, read_record_at, recover_index, stream_messages

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ChannelInfo:
    """One robot's topic in the log. ``problem`` says why it cannot be decoded ("" if it can)."""

    channel_id: int
    robot_id: str
    topic: str
    typename: str
    message_count: int
    mcap_topic: str
    problem: str = ""

    @property
    def decodable(self) -> bool:
        return not self.problem


class LogMessage(NamedTuple):
    """A logged message; ``msg`` is the decoded message, or CDR bytes when ``raw``."""

    log_time_ns: int
    robot_id: str
    topic: str
    typename: str
    msg: Any

    @property
    def raw(self) -> bool:
        return isinstance(self.msg, bytes)


@dataclass(frozen=True)
class Bookmark:
    name: str
    log_time_ns: int
    data: dict[str, Any]


class LogReader:
    """Reads one MCAP file: the summary's indexes when it has them, else one streaming pass
    (progress via ``on_progress(fraction)``) that rebuilds them from every complete chunk.

    Problems that lose data (a cut-off file, a damaged chunk, an undecodable message) never
    raise: they are logged and collected in ``warnings``.
    """

    def __init__(self, path: str | Path, *, on_progress: Callable[[float], None] | None = None) -> None:
        self.path = Path(path)
        self.warnings: list[str] = []
        self._lock = threading.Lock()
        self._decoders: dict[int, Decoder | None] = {}
        self._undecodable: dict[int, str] = {}
        try:
            self._file = open(self.path, "rb")  # noqa: SIM115 - closed by close()
        except OSError as exc:
            raise LogError(f"cannot open log {self.path}: {exc}") from exc
        try:
            self._size = self._file.seek(0, 2)
            self._file.seek(0)
            if self._file.read(len(MAGIC)) != MAGIC:
                raise LogError(f"{self.path} is not an MCAP file (bad magic)")
            self._file.seek(0)
            self._mcap = SeekingReader(self._file)
            header = self._mcap.get_header()
            self.profile, self.library = header.profile, header.library
            self._recovery: Recovery | None = None
            summary = self._indexed_summary()
            if summary is None:
                self._recovery = recover_index(self._file, self._size, on_progress)
                summary = self._recovery.summary
                if self._recovery.problem:
                    self._warn(f"{self.path.name}: {self._recovery.problem}; read the "
                               f"{summary.statistics.message_count if summary.statistics else 0} complete "
                               f"messages before it (log not closed cleanly?)")
        except LogError:
            self._file.close()
            raise
        except Exception as exc:
            self._file.close()
            raise LogError(f"{self.path} is not a readable MCAP file: {exc}") from exc
        self._summary = summary
        self._channels = self._describe_channels(summary)
        if on_progress is not None and self._recovery is None:
            on_progress(1.0)  # the index was there: nothing to scan

    def _warn(self, text: str) -> None:
        log.warning("%s", text)
        self.warnings.append(text)

    def _indexed_summary(self) -> Summary | None:
        """The file's own summary if it is complete enough to seek with, else None."""
        if self._size < 2 * len(MAGIC) + 29:
            return None
        self._file.seek(self._size - len(MAGIC))
        if self._file.read(len(MAGIC)) != MAGIC:
            return None
        try:
            summary = self._mcap.get_summary()
        except Exception as exc:
            self._warn(f"{self.path.name}: summary section unreadable ({exc}); rebuilding the index")
            return None
        if summary is None or summary.statistics is None:
            return None
        stats = summary.statistics
        if stats.message_count and not summary.chunk_indexes:
            return None  # unchunked file: messages are only found by streaming
        if any(cid not in summary.channels for cid in stats.channel_message_counts):
            return None  # channels not repeated in the summary
        return summary

    # -- what is in the log ------------------------------------------------------------------

    def _describe_channels(self, summary: Summary) -> dict[int, ChannelInfo]:
        counts = summary.statistics.channel_message_counts if summary.statistics else {}
        infos: dict[int, ChannelInfo] = {}
        by_schema: dict[tuple[int, str], tuple[Decoder | None, str]] = {}  # many robots share a schema
        for cid, channel in summary.channels.items():
            schema = summary.schemas.get(channel.schema_id)
            robot_id, topic = split_channel(channel.topic, channel.metadata)
            typename = full_typename(schema.name) if schema else ""
            key = (channel.schema_id, channel.message_encoding)
            if key not in by_schema:
                try:
                    by_schema[key] = (make_decoder(channel, schema), "")
                except UndecodableChannel as exc:
                    by_schema[key] = (None, str(exc))
            self._decoders[cid], problem = by_schema[key]
            if problem:
                log.info("%s: channel %s yields raw bytes: %s", self.path.name, channel.topic, problem)
            infos[cid] = ChannelInfo(cid, robot_id, topic, typename, counts.get(cid, 0), channel.topic, problem)
        return infos

    @property
    def indexed(self) -> bool:
        """True when the file's own summary was used (a cleanly closed log)."""
        return self._recovery is None

    @property
    def channels(self) -> list[ChannelInfo]:
        """Every data channel (bookmarks excluded), by robot then topic."""
        return sorted((c for c in self._channels.values() if c.topic != BOOKMARK_TOPIC or c.robot_id),
                      key=lambda c: (c.robot_id, c.topic, c.channel_id))

    @property
    def topics(self) -> dict[str, str]:
        """Topic name -> type name, over all robots."""
        return {c.topic: c.typename for c in self.channels}

    @property
    def robots(self) -> list[str]:
        return sorted({c.robot_id for c in self.channels})

    @property
    def message_count(self) -> int:
        """Messages on data channels (what messages() yields without filters)."""
        return sum(c.message_count for c in self.channels)

    @property
    def start_ns(self) -> int:
        stats = self._summary.statistics
        return stats.message_start_time if stats and stats.message_count else 0

    @property
    def end_ns(self) -> int:
        stats = self._summary.statistics
        return stats.message_end_time if stats and stats.message_count else 0

    @property
    def duration(self) -> float:
        """Seconds from the first to the last message."""
        return (self.end_ns - self.start_ns) / 1e9

    # -- messages ------------------------------------------------------------------------------

    def _wanted(self, topics: Collection[str] | None, robots: Collection[str] | None) -> set[int]:
        topic_set = None if topics is None else {t.lstrip("/") for t in topics} | set(topics)
        wanted = set()
        for cid, info in self._channels.items():
            if topic_set is None and info.topic == BOOKMARK_TOPIC and not info.robot_id:
                continue
            if topic_set is not None and info.topic not in topic_set and info.mcap_topic not in topic_set:
                continue
            if robots is not None and info.robot_id not in robots:
                continue
            wanted.add(cid)
        return wanted

    def messages(
        self,
        start_ns: int | None = None,
        end_ns: int | None = None,
        topics: Collection[str] | None = None,
        robots: Collection[str] | None = None,
        decode: bool = True,
    ) -> Iterator[LogMessage]:
        """Messages with ``start_ns <= log_time < end_ns`` in log-time order.

        Only the chunks overlapping the range (and holding a wanted channel) are read, so
        starting anywhere in a large log is fast. ``topics`` are topic names as ``channels()``
        lists them (or the MCAP channel topic); ``robots`` are robot ids.
        """
        if topics is not None and isinstance(topics, str):
            topics = [topics]
        if robots is not None and isinstance(robots, str):
            robots = [robots]
        wanted = self._wanted(topics, robots)
        if not wanted:
            return
        if self._recovery is not None and self._recovery.loose_messages:
            source = self._streamed(wanted, start_ns, end_ns)
        else:
            source = self._merged(wanted, start_ns, end_ns)
        for message in source:
            info = self._channels[message.channel_id]
            payload: Any = message.data
            if decode:
                payload = self._decode(info, message.data)
            yield LogMessage(message.log_time, info.robot_id, info.topic, info.typename, payload)

    def _decode(self, info: ChannelInfo, data: bytes) -> Any:
        decoder = self._decoders.get(info.channel_id)
        if decoder is None:
            return data
        try:
            return decoder(data)
        except Exception as exc:  # a payload that is not what its schema says
            if info.channel_id not in self._undecodable:
                self._undecodable[info.channel_id] = str(exc)
                self._warn(f"{self.path.name}: a message on {info.mcap_topic} does not decode as "
                           f"{info.typename} ({exc}); yielding raw bytes")
            return data

    def _chunks(self, wanted: set[int], start_ns: int | None, end_ns: int | None) -> list[ChunkIndex]:
        chosen = []
        for index in self._summary.chunk_indexes:
            if start_ns is not None and index.message_end_time < start_ns:
                continue
            if end_ns is not None and index.message_start_time >= end_ns:
                continue
            if index.message_index_offsets and not wanted.intersection(index.message_index_offsets):
                continue
            chosen.append(index)
        chosen.sort(key=lambda i: (i.message_start_time, i.chunk_start_offset))
        return chosen

    def _load(self, index: ChunkIndex) -> list[Message]:
        try:
            with self._lock:
                return chunk_messages(self._file, index)
        except Exception as exc:  # a damaged chunk loses its messages, not the whole replay
            self._warn(f"{self.path.name}: chunk at byte {index.chunk_start_offset} unreadable ({exc}); skipped")
            return []

    def _merged(self, wanted: set[int], start_ns: int | None, end_ns: int | None) -> Iterator[Message]:
        """Chunks may overlap in time: merge them, opening a chunk only when its first
        message could be next."""
        chunks = self._chunks(wanted, start_ns, end_ns)
        heap: list[tuple[int, int, int, Message]] = []
        next_chunk = 0
        while next_chunk < len(chunks) or heap:
            while next_chunk < len(chunks) and (not heap or chunks[next_chunk].message_start_time <= heap[0][0]):
                index = chunks[next_chunk]
                next_chunk += 1
                for position, message in enumerate(self._load(index)):
                    if message.channel_id not in wanted:
                        continue
                    if start_ns is not None and message.log_time < start_ns:
                        continue
                    if end_ns is not None and message.log_time >= end_ns:
                        continue
                    heapq.heappush(heap, (message.log_time, index.chunk_start_offset, position, message))
            if heap:
                yield heapq.heappop(heap)[3]

    def _streamed(self, wanted: set[int], start_ns: int | None, end_ns: int | None) -> Iterator[Message]:
        """Unchunked files have no index to seek with: read them front to back (file order)."""
        with open(self.path, "rb") as stream:
            for message in stream_messages(stream, self._size):
                if message.channel_id not in wanted:
                    continue
                if start_ns is not None and message.log_time < start_ns:
                    continue
                if end_ns is not None and message.log_time >= end_ns:
                    continue
                yield message

    # -- bookmarks -----------------------------------------------------------------------------

    def _metadata(self) -> list[Metadata]:
        if self._recovery is not None:
            return self._recovery.metadata
        found = []
        for index in self._summary.metadata_indexes:
            if index.name != BOOKMARK_METADATA_NAME:
                continue
            try:
                with self._lock:
                    record = read_record_at(self._file, index.offset)
            except ValueError as exc:
                self._warn(f"{self.path.name}: metadata record unreadable ({exc})")
                continue
            if isinstance(record, Metadata):
                found.append(record)
        return found

    @functools.cached_property
    def bookmarks(self) -> list[Bookmark]:
        """Bookmarks from the bookmark channel and the ``bookmark`` metadata records, by time (read once)."""
        marks: dict[tuple[int, str], Bookmark] = {}
        for record in self._metadata():
            if record.name != BOOKMARK_METADATA_NAME:
                continue
            try:
                mark = Bookmark(record.metadata["name"], int(record.metadata["log_time_ns"]),
                                json.loads(record.metadata.get("data", "{}")))
            except (KeyError, ValueError) as exc:
                self._warn(f"{self.path.name}: bookmark metadata {record.metadata} unreadable ({exc})")
                continue
            marks[(mark.log_time_ns, mark.name)] = mark
        for item in self.messages(topics=[BOOKMARK_TOPIC], robots=[""]):
            try:
                content = json.loads(item.msg.data)
                mark = Bookmark(str(content["name"]), int(content["log_time_ns"]), dict(content.get("data", {})))
            except (AttributeError, KeyError, TypeError, ValueError) as exc:
                self._warn(f"{self.path.name}: bookmark message unreadable ({exc})")
                continue
            marks.setdefault((mark.log_time_ns, mark.name), mark)
        return sorted(marks.values(), key=lambda m: (m.log_time_ns, m.name))

    # -- lifetime ------------------------------------------------------------------------------

    def schema(self, channel_id: int) -> Schema | None:
        channel: Channel = self._summary.channels[channel_id]
        return self._summary.schemas.get(channel.schema_id)

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> LogReader:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
