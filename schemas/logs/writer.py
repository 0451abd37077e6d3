"""LogWriter: pitchside messages into chunked, indexed, size-rotated MCAP files (ros2 profile)."""

from __future__ import annotations

import contextlib
import json
import os
import threading
import time
from pathlib import Path
from types import TracebackType
from typing import Any

from mcap.writer import CompressionType, Writer

from schemas import codec
from schemas.logs.naming import (
    BOOKMARK_METADATA_NAME,
    BOOKMARK_TOPIC,
    BOOKMARK_TYPE,
    LogError,
    channel_topic,
    next_series_index,
    rotated_path,
)
from schemas.std import String
from schemas.topics import TOPICS

_COMPRESSION = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE,
                "": CompressionType.NONE}


class _ChunkFlushingFile:
    """An unbuffered file for mcap's Writer: each finished record (a whole chunk, its message
    indexes, a metadata record) goes to the operating system at once, so a crash of the
    process loses at most the chunk still being filled in memory."""

    def __init__(self, path: Path) -> None:
        self._fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        self._position = 0
        self.last_write = time.monotonic()

    def write(self, data: bytes | bytearray | memoryview) -> int:
        view = memoryview(data)
        while view:
            written = os.write(self._fd, view)
            view = view[written:]
        self._position += len(data)
        if data:
            self.last_write = time.monotonic()
        return len(data)

    def tell(self) -> int:
        return self._position

    def flush(self) -> None:
        """Nothing is buffered here; the Writer's flush() lands in the file already."""

    def fsync(self) -> None:
        os.fsync(self._fd)

    def close(self) -> None:
        os.close(self._fd)


class LogWriter:
    """Writes messages of many robots into one MCAP log that Foxglove, `mcap` and `ros2 bag` open.

    Channel topic is ``/<robot_id>/<topic>`` with metadata ``{"robot_id", "topic"}``; message
    encoding ``cdr``, schemas ``ros2msg`` with the full definition text. Files are chunked and
    fully indexed (statistics, chunk and message indexes), rotated to ``<stem>_001.mcap`` ...
    before a file passes ``rotate_bytes`` (only its summary, i.e. repeated schemas, channels and
    indexes, and an incompressible chunk's overhead can go beyond).

    Crash safety: a chunk goes to the operating system as soon as it is full, or at the next
    write once ``flush_interval_s`` has passed since the last one (or on ``flush()``), so a
    crashed process loses at most the chunk being filled. With ``continue_series`` the log
    goes on after the files of its series already on disk (``<stem>_00n.mcap``), so a
    recording a crash cut off and its continuation read back as one (LogSeriesReader).
    Thread-safe.
    """

    def __init__(
        self,
        path: str | Path,
        *,
        chunk_size: int = 1 << 20,
        compression: str = "zstd",
        rotate_bytes: int | None = None,
        profile: str = "ros2",
        flush_interval_s: float | None = 2.0,
        continue_series: bool = False,
    ) -> None:
        if compression not in _COMPRESSION:
            raise LogError(f"compression must be one of {sorted(_COMPRESSION)}, not {compression!r}")
        if chunk_size <= 0:
            raise LogError(f"chunk_size must be positive, not {chunk_size}")
        if rotate_bytes is not None and rotate_bytes <= 0:
            raise LogError(f"rotate_bytes must be positive or None, not {rotate_bytes}")
        self.path = Path(path)
        self.paths: list[Path] = []
        self.message_count = 0
        self._chunk_size = chunk_size
        self._compression = _COMPRESSION[compression]
        self._rotate_bytes = rotate_bytes
        self._profile = profile
        self._flush_interval_s = flush_interval_s
        self._lock = threading.Lock()
        self._channels: dict[tuple[str, str, str], int] = {}
        self._schemas: dict[str, int] = {}
        self._sequence: dict[int, int] = {}
        self._pending = 0
        self._first_index = next_series_index(self.path) if continue_series else 0
        self._file: _ChunkFlushingFile | None = None
        self._writer: Writer | None = None
        self._open_next()

    # -- files --------------------------------------------------------------------------------

    def _open_next(self) -> None:
        path = rotated_path(self.path, self._first_index + len(self.paths))
        path.parent.mkdir(parents=True, exist_ok=True)
        self._file = _ChunkFlushingFile(path)
        self._writer = Writer(self._file, chunk_size=self._chunk_size, compression=self._compression)  # type: ignore[arg-type]
        self._writer.start(profile=self._profile, library="pitchside")
        self._channels.clear()
        self._schemas.clear()
        self._sequence.clear()
        self._pending = 0
        self.paths.append(path)

    def _finish_file(self) -> None:
        if self._writer is not None and self._file is not None:
            self._writer.finish()
            self._file.close()
        self._writer = None
        self._file = None

    def _live(self) -> tuple[Writer, _ChunkFlushingFile]:
        if self._writer is None or self._file is None:
            raise LogError(f"log {self.path} is closed")
        return self._writer, self._file

    # -- channels -----------------------------------------------------------------------------

    def _channel(self, robot_id: str, topic: str, typename: str) -> int:
        key = (robot_id, topic, typename)
        channel_id = self._channels.get(key)
        if channel_id is None:
            writer, _ = self._live()
            schema_id = self._schemas.get(typename)
            if schema_id is None:
                schema_id = writer.register_schema(typename, "ros2msg", codec.msgdef(typename).encode())
                self._schemas[typename] = schema_id
            metadata = {"robot_id": robot_id, "topic": topic}
            channel_id = writer.register_channel(channel_topic(robot_id, topic), "cdr", schema_id, metadata)
            self._channels[key] = channel_id
        return channel_id

    # -- writing ------------------------------------------------------------------------------

    def write(
        self,
        robot_id: str,
        topic: str,
        msg_or_cdr_bytes: codec.Message | bytes | bytearray | memoryview,
        typename: str | None = None,
        log_time_ns: int | None = None,
        publish_time_ns: int | None = None,
    ) -> None:
        """Logs one message (a rosbags message object, or its CDR bytes with the type name;
        for bytes the type defaults to the topic table's). Times default to now."""
        if isinstance(msg_or_cdr_bytes, bytes | bytearray | memoryview):
            data = bytes(msg_or_cdr_bytes)
            if typename is None:
                known = TOPICS.get(topic)
                if known is None:
                    raise LogError(f"CDR bytes on topic {topic!r} need a typename (not in the topic table)")
                typename = known.type
        else:
            msgtype = getattr(msg_or_cdr_bytes, "__msgtype__", None)
            if msgtype is None:
                raise LogError(f"cannot log {type(msg_or_cdr_bytes).__name__}: not a message or CDR bytes")
            typename = typename or msgtype
            data = codec.encode(msg_or_cdr_bytes)
        typename = codec.full_name(typename)
        log_time = time.time_ns() if log_time_ns is None else int(log_time_ns)
        publish_time = log_time if publish_time_ns is None else int(publish_time_ns)
        with self._lock:
            self._add(robot_id, topic, typename, data, log_time, publish_time)

    def _add(self, robot_id: str, topic: str, typename: str, data: bytes, log_time: int, publish_time: int) -> None:
        writer, file = self._live()
        channel_id = self._channel(robot_id, topic, typename)
        sequence = self._sequence.get(channel_id, 0)
        self._sequence[channel_id] = sequence + 1
        before = file.tell()
        writer.add_message(channel_id, log_time, data, publish_time, sequence)
        self.message_count += 1
        self._pending = 0 if file.tell() != before else self._pending + 1
        if (self._pending and self._flush_interval_s is not None
                and time.monotonic() - file.last_write >= self._flush_interval_s):
            writer.flush()
            self._pending = 0
        # Rotate when the next full chunk might not fit, so a file stays within rotate_bytes plus its summary.
        if self._rotate_bytes is not None and file.tell() + self._chunk_size >= self._rotate_bytes:
            self._finish_file()
            self._open_next()

    def add_bookmark(self, name: str, log_time_ns: int | None = None, data: dict[str, Any] | None = None) -> None:
        """Marks a moment (a goal, a fall) for replay.

        Written twice on purpose: as a message on channel ``/pitchside/bookmarks``
        (std_msgs/msg/String carrying JSON ``{"name", "log_time_ns", "data"}``), so it is
        time-indexed and appears on Foxglove's timeline and in any player; and as an MCAP
        metadata record named ``bookmark`` (``mcap list metadata``, Foxglove's metadata view),
        which goes to the file immediately and so survives a crash even if its chunk does not.
        """
        log_time = time.time_ns() if log_time_ns is None else int(log_time_ns)
        try:
            payload = json.dumps({"name": name, "log_time_ns": log_time, "data": data or {}})
        except (TypeError, ValueError) as exc:
            raise LogError(f"bookmark {name!r} data is not JSON-serializable: {exc}") from exc
        cdr = codec.encode(String(data=payload))
        with self._lock:
            writer, _ = self._live()
            writer.add_metadata(BOOKMARK_METADATA_NAME, {"name": name, "log_time_ns": str(log_time),
                                                         "data": json.dumps(data or {})})
            self._add("", BOOKMARK_TOPIC, BOOKMARK_TYPE, cdr, log_time, log_time)

    def flush(self) -> None:
        """Ends the current chunk and hands it to the operating system (e.g. when the stream pauses)."""
        with self._lock:
            if self._writer is not None:
                self._writer.flush()
                self._pending = 0

    def close(self) -> None:
        """Writes the summary (statistics, indexes) and closes the file; idempotent."""
        with self._lock:
            self._finish_file()

    def abandon(self) -> None:
        """Closes the file without its summary, as a crash would leave it (its complete chunks read back): for a
        disk that is full or read-only, where the summary cannot be written either; idempotent."""
        with self._lock:
            if self._file is not None:
                with contextlib.suppress(OSError):
                    self._file.close()
            self._writer = None
            self._file = None

    def __enter__(self) -> LogWriter:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
