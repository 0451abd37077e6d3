"""HubRecording: one hub subscriber whose messages go into one (size-rotated) MCAP log in ``recordings/``."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import shutil
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from schemas import codec
from schemas.logs import LogError, LogWriter, rotated_path
from schemas.logs.naming import next_series_index
from server.hub import Hub, HubMessage, Subscriber
from server.recording.scene import SCENE_TOPICS, RecordedScene

log = logging.getLogger(__name__)

QUEUE_MAXLEN = 100_000  # messages waiting for the writer thread; beyond, the oldest go (and are counted)
WAKE_S = 0.25
# what comes within this long goes to the writer thread as one batch: a hand-over per message cost the server more
# than writing it (8 robots: about a thousand messages a second); CRASH_LOSS_BOUND_S holds with it
BATCH_S = 0.1
# The open chunk goes to disk at the first write this long after the last one (or after this long of quiet), so
# a killed server's file holds every message it received until CRASH_LOSS_BOUND_S before the kill: the product's
# promise (README, Recording), with room for a busy machine's scheduling above the flush interval.
IDLE_FLUSH_S = 0.2
CRASH_LOSS_BOUND_S = 0.5
# A recording opens with each stream's newest message (the state a replay starts from) if it is at most this old:
# an older one is stale news (a robot gone minutes ago, the last half's game state) and would stretch the timeline.
OPENING_FRESH_S = 2.0
# A disk that is full or read-only: the file so far is closed as a crash would leave it (complete chunks), what
# comes meanwhile is counted as lost, and every DISK_RETRY_S a new file of the series is tried once the folder has
# DISK_MARGIN_BYTES free again; the error shows on the page until then.
DISK_RETRY_S = 1.0
DISK_MARGIN_BYTES = 2 << 20


@dataclass(slots=True)
class RecordingStatus:
    """What the UI shows of a running (or finished) recording."""

    name: str
    path: str
    reason: str  # "manual", "match", "cli"
    started: float  # wall clock
    stopped: float | None = None
    messages: int = 0  # handed to the writer (the hub messages and the /tf, /tf_static, robot_description of them)
    flushed_messages: int = 0  # known to be on disk (the writer's chunks handed to the OS)
    skipped: int = 0  # messages that cannot be stored (no CDR, unknown type)
    dropped: int = 0  # lost because the writer fell behind
    bookmarks: int = 0
    files: list[str] = field(default_factory=list)
    error: str = ""
    resumed: bool = False  # continues a recording that a crash of the server cut off (next file of its series)
    lost_to_disk: int = 0  # messages not written while the disk was full or read-only

    def as_dict(self) -> dict[str, Any]:
        end = self.stopped or time.time()
        return {"name": self.name, "path": self.path, "reason": self.reason, "started": self.started,
                "stopped": self.stopped, "running": self.stopped is None, "duration_s": round(end - self.started, 3),
                "messages": self.messages, "flushed_messages": self.flushed_messages, "skipped": self.skipped,
                "dropped": self.dropped, "bookmarks": self.bookmarks, "files": self.files, "error": self.error,
                "resumed": self.resumed, "lost_to_disk": self.lost_to_disk}


def storable(msg: HubMessage) -> tuple[str, str, bytes] | None:
    """(topic, typename, CDR) of a hub message as the log stores it, or None when it cannot be stored."""
    try:
        return msg.topic, codec.full_name(msg.typename), msg.cdr
    except Exception:  # a foreign (replayed) type or a message object that does not encode
        return None


class RecorderSubscriber(Subscriber):
    """A hub subscriber whose images share the big queue: a browser may skip images, a recording must not
    (the hub keeps only a few images per subscriber, enough for a display, not for a writer between batches).
    It takes what arrives late after a link cut too: old for a display, still the robot's data for the log."""

    def __init__(self, hub: Hub, name: str, maxlen: int) -> None:
        super().__init__(hub, name, maxlen, include_late=True)
        self._bulk = deque(maxlen=maxlen)


class HubRecording:
    """Subscribes to every robot and topic of the hub and writes to ``path`` (rotated ``path_001.mcap`` ...).

    Draining happens on the event loop; encoding and writing (zstd chunks) on a worker thread, so the
    loop is never blocked by the disk. The LogWriter hands each finished chunk to the OS at once and the
    recording flushes an open chunk after ``IDLE_FLUSH_S`` of quiet: a killed server loses at most one chunk,
    no more than ``CRASH_LOSS_BOUND_S``. ``resume``: the recording at ``path`` was cut off by a crash; go on
    in the next file of its series. ``scene``: also write the robots' /tf, /tf_static and robot_description
    (server.recording.scene), so the recording shows them in 3D.
    """

    def __init__(self, hub: Hub, path: Path, reason: str, *, rotate_bytes: int | None = None,
                 chunk_size: int = 1 << 20, include_sources: frozenset[str] | None = None,
                 resume: bool = False, scene: RecordedScene | None = None) -> None:
        self.hub = hub
        self.path = path
        self.scene = scene
        self.include_sources = include_sources  # None: every source except replay
        self.status = RecordingStatus(path.stem, str(path), reason, time.time(), resumed=resume)
        self._wall_offset = time.time() - time.monotonic()
        self._chunk_size, self._rotate_bytes = chunk_size, rotate_bytes
        self._done_paths: list[Path] = []  # files of earlier writers (before a disk error)
        self._writer: LogWriter | None = None
        self._retry_at = 0.0
        self._open_writer(continue_series=resume)
        self._sub = RecorderSubscriber(hub, f"recorder:{path.stem}", QUEUE_MAXLEN)
        hub.subscribers.append(self._sub)
        self._sub.subscribe("*", "*", replay_latest=False)
        fresh_since = time.monotonic() - OPENING_FRESH_S
        for msg in sorted(hub.latest.values(), key=lambda m: m.received):
            if msg.received >= fresh_since:
                self._sub.offer(msg)
        self._unflushed = 0
        self._stop_asked = asyncio.Event()
        self._task: asyncio.Task[None] | None = asyncio.get_running_loop().create_task(self._run())

    def wanted(self, msg: HubMessage) -> bool:
        if self.include_sources is None:
            return msg.source != "replay"
        return msg.source in self.include_sources

    async def _run(self) -> None:
        last_write = time.monotonic()
        while not self._stop_asked.is_set():
            if not await self._sub.wait(timeout=WAKE_S):
                if self._unflushed and time.monotonic() - last_write >= IDLE_FLUSH_S:
                    await asyncio.to_thread(self._flush)
                continue
            with contextlib.suppress(TimeoutError):  # a stop does not wait for the batch to fill
                async with asyncio.timeout(BATCH_S):
                    await self._stop_asked.wait()
            batch = [m for m in self._sub.drain(limit=QUEUE_MAXLEN) if self.wanted(m)]
            self.status.dropped = self._sub.dropped
            if batch:
                await asyncio.to_thread(self._write, batch)
                last_write = time.monotonic()

    # -- the disk -------------------------------------------------------------------------------------------
    def _open_writer(self, continue_series: bool) -> None:
        """A writer for the next file of the series; on a disk error the recording waits (status.error says why)."""
        next_path = rotated_path(self.path, next_series_index(self.path)) if continue_series else self.path
        existed = next_path.exists()
        try:
            self._writer = LogWriter(self.path, chunk_size=self._chunk_size, rotate_bytes=self._rotate_bytes,
                                     flush_interval_s=IDLE_FLUSH_S, continue_series=continue_series)
        except OSError as exc:
            if not existed:  # a header cut short is no log: leave no file that does not open
                with contextlib.suppress(OSError):
                    next_path.unlink(missing_ok=True)
            self._disk_failed(exc)
            return
        if self.status.error:
            log.warning("recording %s goes on in %s: the disk takes data again", self.path.name,
                        self._writer.paths[0].name)
        self.status.error = ""
        self._sync_files()

    def _disk_failed(self, exc: OSError) -> None:
        """The disk is full or read-only: keep what the file has (complete chunks), try again later."""
        writer, self._writer = self._writer, None
        if writer is not None:
            self._done_paths += writer.paths
            writer.abandon()
        if not self.status.error:
            log.error("recording %s paused: %s", self.path.name, exc)
        self.status.error = f"cannot write to {self.path.parent}: {exc.strerror or exc} (what was recorded is kept; " \
                            "recording goes on when the disk takes data again)"
        self._unflushed = 0
        self.status.flushed_messages = self.status.messages
        self._retry_at = time.monotonic() + DISK_RETRY_S
        self._sync_files()

    def _writable(self) -> bool:
        """Whether to write now: a writer, or a new one once the folder has room again (tried every DISK_RETRY_S)."""
        if self._writer is not None:
            return True
        if time.monotonic() < self._retry_at:
            return False
        self._retry_at = time.monotonic() + DISK_RETRY_S
        try:
            if shutil.disk_usage(self.path.parent).free < DISK_MARGIN_BYTES:
                return False
        except OSError:
            return False
        self._open_writer(continue_series=True)
        return self._writer is not None

    def _sync_files(self) -> None:
        self.status.files = [str(p) for p in [*self._done_paths, *(self._writer.paths if self._writer else [])]]

    # -- writing ---------------------------------------------------------------------------------------------
    def _write(self, batch: list[HubMessage]) -> None:
        """On a worker thread."""
        for msg in batch:
            if not self._writable():
                self.status.lost_to_disk += 1
                continue
            # the robot's own latched URDF and fixed joints: the scene writes them with the robot's frame names
            stored = None if self.scene is not None and msg.topic in SCENE_TOPICS else storable(msg)
            if stored is None:
                self.status.skipped += 1
                continue
            topic, typename, cdr = stored
            log_time = int((msg.received + self._wall_offset) * 1e9)
            try:
                assert self._writer is not None
                self._writer.write(msg.robot, topic, cdr, typename, log_time_ns=log_time,
                                   publish_time_ns=int(msg.stamp * 1e9))
            except (LogError, codec.SchemaError, ValueError) as exc:
                self.status.skipped += 1
                log.debug("not recorded: %s/%s: %s", msg.robot, msg.topic, exc)
                continue
            except OSError as exc:
                self.status.lost_to_disk += 1
                self._disk_failed(exc)
                continue
            self.status.messages += 1
            self._unflushed += 1
            if self.scene is not None:
                self._write_scene(msg, log_time)
        self._sync_files()

    def _write_scene(self, msg: HubMessage, log_time: int) -> None:
        assert self.scene is not None
        for record in self.scene.records(msg, len(self.status.files)):
            if self._writer is None:
                return
            try:
                self._writer.write(record.robot, record.topic, record.cdr, record.typename, log_time_ns=log_time,
                                   publish_time_ns=int(msg.stamp * 1e9))
            except (LogError, codec.SchemaError, ValueError) as exc:
                log.debug("not recorded: %s/%s: %s", record.robot, record.topic, exc)
                continue
            except OSError as exc:
                self._disk_failed(exc)
                return
            self.status.messages += 1  # what the file holds: the robots' streams and their 3D scene
            self._unflushed += 1

    def _flush(self) -> None:
        if self._writer is not None:
            try:
                self._writer.flush()
            except OSError as exc:
                self._disk_failed(exc)
                return
        self._unflushed = 0
        self.status.flushed_messages = self.status.messages

    def bookmark(self, name: str, data: dict[str, Any] | None = None, log_time_ns: int | None = None) -> None:
        """A named moment (a goal, a penalty) on the recording's timeline; goes to disk at once. LogError while the
        disk takes no data."""
        if self._writer is None:
            raise LogError(f"not written: {self.status.error}")
        try:
            self._writer.add_bookmark(name, log_time_ns=log_time_ns, data=data)
        except OSError as exc:
            self._disk_failed(exc)
            raise LogError(f"not written: {self.status.error}") from exc
        self.status.bookmarks += 1

    async def stop(self) -> RecordingStatus:
        """Writes what is queued, then the summary; the files are complete MCAP logs afterwards."""
        task, self._task = self._task, None
        if task is not None:
            self._stop_asked.set()
            with contextlib.suppress(Exception):
                await task  # ends within WAKE_S, after the batch it is writing
            self._sub.close()
            rest = [m for m in self._sub.drain(limit=QUEUE_MAXLEN) if self.wanted(m)]
            await asyncio.to_thread(self._write, rest)
            await asyncio.to_thread(self._close_writer)
            self.status.flushed_messages = self.status.messages
            self.status.stopped = time.time()
        return self.status

    def _close_writer(self) -> None:
        if self._writer is None:
            return
        try:
            self._writer.close()
        except OSError as exc:  # the summary did not fit: the file stays as a crash leaves it
            self._disk_failed(exc)

    @property
    def running(self) -> bool:
        return self._task is not None
