"""The replay source: feeds the hub from an MCAP log (a pitchside recording or another team's ROS 2 bag).

Panels see replayed messages as they see live ones (same hub, source "replay"), but under robots of their own:
robot ``r1`` of the log is ``replay.r1`` in the hub (wire.keys.replayed_robot_id), so a replay never merges with a
live robot of the same id, live data goes on beside it, and no command can reach a robot through a replayed id
(the control API takes robot ids by the naming rule only). Channels without a robot (a ROS 2 bag's ``/rosout``)
are robot ``replay.log``; topics the topic table knows reach their panels, others arrive as ordinary msg frames
whose numeric fields the replay panel can plot. Closing the log takes its robots out of the hub.

The timeline starts at the log's real data (schemas.logs.data_start_ns): stale messages a recording opened with
are skipped, not played minutes before the half.

A player thread reads the log in time order and paces it against the wall clock at ``speed`` (0.1x-10x);
play, pause, step, seek and speed changes come from the event loop. At most ``MAX_IN_FLIGHT`` batches wait
for the loop, so a replay faster than the hub can take slows down instead of piling up memory.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import heapq
import json
import logging
import math
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from rosbags.typesys import get_types_from_msg

from schemas import codec
from schemas.logs import (
    Bookmark,
    ChannelInfo,
    LogError,
    LogMessage,
    LogNotes,
    LogReader,
    LogSeriesReader,
    data_start_ns,
)
from schemas.messages import RobotOverview
from schemas.std import String
from schemas.topics import TOPICS
from server.hub import Hub, HubMessage
from server.security import AllowedFolders, FolderError
from server.sources import Source, SourceError
from wire import keys

log = logging.getLogger(__name__)

SOURCE = "replay"
MIN_SPEED, MAX_SPEED = 0.1, 10.0
MAX_IN_FLIGHT = 8  # batches handed to the loop and not yet published
BATCH_S = 0.02  # wall time a batch may gather before it goes to the hub
PREVIEW_S = 1.0  # after a seek: the newest message of each stream from this long before the seek point
OVERVIEW_TOPIC, STRING_TYPE = "overview", "std_msgs/msg/String"
OVERVIEW_TYPE = TOPICS[OVERVIEW_TOPIC].type
_OVERVIEW_FIELDS = frozenset(n for n, _ in codec.typestore().fielddefs[OVERVIEW_TYPE][1])


BAD_NAME = f"robot id or topic breaks the naming rules (robot id: {keys.NAME_RULE}; topic: {keys.TOPIC_RULE})"


def _well_named(robot_id: str, topic: str) -> bool:
    """A channel's names as pitchside takes them from the network (robot "" is a ROS 2 bag's, shown as replay)."""
    return (not robot_id or keys.is_valid_name(robot_id)) and keys.is_valid_topic(topic)


def _table_misfit(reader: LogReader, channel: ChannelInfo) -> str:
    """Why a channel on a topic of the topic table may not be replayed under that name ("" if it may).

    The page, the plots, the 3D view and Foxglove read a table topic as the table's type. A log carries its own
    schemas, so another team's file could give ``rosout`` a ``string level`` where the table has a number, and
    the string would reach places that expect a number (a CSS class, a plot). Such a channel is listed with
    this reason and never reaches the hub; constants may differ (they are names for values, not layout)."""
    row = TOPICS.get(channel.topic)
    if row is None or not channel.decodable:
        return ""
    if channel.topic == OVERVIEW_TOPIC and channel.typename == STRING_TYPE:
        return ""  # an earlier version's overview, converted by _legacy_overview
    if channel.typename != row.type:
        return f"the topic table's {channel.topic!r} is {row.type}, this log's is {channel.typename}"
    schema = reader.schema(channel.channel_id)
    try:
        parsed = get_types_from_msg(schema.data.decode(), channel.typename) if schema is not None else {}
    except Exception:  # rosbags raises several kinds on bad text
        parsed = {}
    shared = codec.typestore().fielddefs
    if not parsed or any(name not in shared or shared[name][1] != fields for name, (_, fields) in parsed.items()):
        return f"this log's {channel.typename} has other fields than pitchside's: not replayed as {channel.topic!r}"
    return ""


class ReplayFile:
    """An opened log: what is in it (for the timeline) and its messages as hub messages."""

    def __init__(self, reader: LogSeriesReader, path: Path) -> None:
        self.reader = reader
        self.path = path
        self.start_ns = data_start_ns(reader)  # after any stale opening messages
        self.end_ns = max(reader.end_ns, self.start_ns)
        self.channels = reader.channels
        self.bookmarks = reader.bookmarks
        # notes a person added while looking at this log: a sidecar beside its first file (schemas.logs.notes)
        self.notes = LogNotes(Path(reader.paths[0]) if reader.paths else path)
        # Channels whose type the process typestore decodes the same way travel as CDR bytes (decoded only
        # where a panel needs them); the others are decoded here with the log's own definitions.
        foreign = {c.mcap_topic for r in reader.readers for c in r.channels if not _shared_schema(r, c)}
        every = {c.mcap_topic for r in reader.readers for c in r.channels}
        self.raw_topics = sorted(every - foreign)
        self.decoded_topics = sorted(foreign)
        # (robot, topic, type) of channels whose type is not the topic table's; a stream with one such channel
        # is not replayed at all (its messages do not say which channel they came from)
        self.misfits: dict[tuple[str, str, str], str] = {}
        for r in reader.readers:
            for c in r.channels:
                if problem := _table_misfit(r, c):
                    self.misfits[(c.robot_id, c.topic, c.typename)] = problem

    def info(self) -> dict[str, Any]:
        topics = [{"robot": keys.replayed_robot_id(c.robot_id), "topic": c.topic, "msgtype": c.typename,
                   "count": c.message_count, "known": c.topic in TOPICS,
                   "decodable": not self.problem(c), "problem": self.problem(c)}
                  for c in self.channels]
        return {"path": str(self.path), "files": [str(p) for p in self.reader.paths], "start_ns": self.start_ns,
                "end_ns": self.end_ns, "duration_s": (self.end_ns - self.start_ns) / 1e9,
                "messages": self.reader.message_count, "topics": topics,
                "robots": sorted({t["robot"] for t in topics}),
                "bookmarks": self.marks(),
                "notes_file": str(self.notes.path),
                "warnings": [*self.reader.warnings[-20:], *([self.notes.problem] if self.notes.problem else [])]}

    def marks(self) -> list[dict[str, Any]]:
        """The log's own bookmarks (kind "log": GameController events, bookmarks made while recording) and the
        notes added since (kind "note"), by time; those before the timeline's start are left out."""
        marks = [(b, "log") for b in self.bookmarks] + [(b, "note") for b in self.notes.notes]
        return [self.mark(b, kind) for b, kind in sorted(marks, key=lambda m: (m[0].log_time_ns, m[0].name))
                if b.log_time_ns >= self.start_ns]

    def mark(self, bookmark: Bookmark, kind: str) -> dict[str, Any]:
        return {"name": bookmark.name, "t_s": (bookmark.log_time_ns - self.start_ns) / 1e9,
                "log_time_ns": bookmark.log_time_ns, "data": bookmark.data, "kind": kind}

    def problem(self, channel: ChannelInfo) -> str:
        """Why the channel is not replayed ("" if it is): it does not decode, a name breaks the rules, or its type
        is not the topic table's."""
        if channel.problem:
            return channel.problem
        if not _well_named(channel.robot_id, channel.topic):
            return BAD_NAME
        return self.misfits.get((channel.robot_id, channel.topic, channel.typename), "")

    def hub_message(self, item: LogMessage) -> HubMessage | None:
        """None for a message that did not decode (its channel is still listed, with the problem)."""
        robot = keys.replayed_robot_id(item.robot_id)
        if not _well_named(item.robot_id, item.topic):
            return None  # a name from a foreign file that breaks the rules never reaches the hub (or a page)
        if (item.robot_id, item.topic, item.typename) in self.misfits:
            return None  # a table topic as another type: never where panels expect the table's
        typename, data = item.typename, item.msg
        if item.raw and item.topic not in self._raw_names:
            return None  # a channel without a usable schema
        if item.topic == OVERVIEW_TOPIC and typename == STRING_TYPE:
            # a recording of an earlier version stored telemetry's overview as JSON text
            overview = _legacy_overview(data)
            if overview is None:
                return None
            typename, data = OVERVIEW_TYPE, overview
        return HubMessage(robot, item.topic, typename, item.log_time_ns / 1e9, data, SOURCE)

    @functools.cached_property
    def _raw_names(self) -> frozenset[str]:
        return frozenset(c.topic for c in self.channels if c.mcap_topic in set(self.raw_topics))

    def messages(self, start_ns: int | None = None, end_ns: int | None = None) -> Iterator[LogMessage]:
        """In log time: known types as CDR bytes, foreign ones decoded."""
        streams = []
        if self.raw_topics:
            streams.append(self.reader.messages(start_ns, end_ns, topics=self.raw_topics, decode=False))
        if self.decoded_topics:
            streams.append(self.reader.messages(start_ns, end_ns, topics=self.decoded_topics, decode=True))
        return heapq.merge(*streams, key=lambda m: m.log_time_ns)

    def close(self) -> None:
        self.reader.close()


def _shared_schema(reader: LogReader, channel: ChannelInfo) -> bool:
    """True when the channel's schema text defines its types exactly as the process typestore does."""
    if not channel.decodable:
        return False
    schema = reader.schema(channel.channel_id)
    shared = codec.typestore().fielddefs
    if schema is None or channel.typename not in shared:
        return False
    try:
        parsed = get_types_from_msg(schema.data.decode(), channel.typename)
    except Exception:  # rosbags raises several kinds on bad text; such a channel is not ours anyway
        return False
    return all(shared.get(name) == definition for name, definition in parsed.items())


def _legacy_overview(data: Any) -> RobotOverview | None:
    """The RobotOverview message of an overview an earlier version recorded as JSON in a std_msgs/String (CDR
    bytes or decoded), NaN as null; None if it is not one."""
    try:
        raw = isinstance(data, bytes | bytearray | memoryview)
        text = codec.decode(data, String).data if raw else data.data
        fields = json.loads(text)
        if not isinstance(fields, dict):
            return None
        known = {name: (math.nan if value is None else value) for name, value in fields.items()
                 if name in _OVERVIEW_FIELDS}
        # through CDR and back: a field of the wrong type or range is refused here, not in a panel
        return codec.decode(codec.encode(codec.make(RobotOverview, **known)), RobotOverview)
    except Exception:  # rosbags and json raise several kinds on bad input; such a message is skipped
        return None


class ReplayRefused(SourceError):
    """A log outside the folders replay may open from."""


class LogNotFound(SourceError):
    """No log file of that name (in the recordings folder, or at that path)."""


class UnreadableLog(SourceError):
    """The file is there but is no log replay can read."""


class NoLogOpen(SourceError):
    """A timeline control or the log's contents asked for while no log is open."""


class BadTimelineRequest(SourceError):
    """A speed or a position the timeline cannot take."""


class ReplaySource(Source):
    """Plays one log into the hub; the state the timeline shows is ``status()``."""

    name = "replay"

    def __init__(self, hub: Hub, folder: Path | None = None, allowed: AllowedFolders | None = None) -> None:
        """folder: where bare names are looked up; allowed: the only folders logs open from (None: anywhere,
        for tools and benchmarks; the server always passes its recordings and command-line folders)."""
        super().__init__()
        self.hub = hub
        self.folder = folder
        self.allowed = allowed
        self.file: ReplayFile | None = None
        self._loading: Path | None = None  # the log being opened: the status names it before it is read
        self.state = "closed"  # closed, loading, paused, playing, ended
        self.progress = 0.0  # of reading a file without an index
        self.speed = 1.0
        self.delivered = 0
        self.skipped = 0
        self.position_ns = 0
        self.seeks = 0  # counts seeks, whoever asked: the Foxglove endpoint tells its clients (did_seek)
        self._next_ns = 0  # the next message to play is at or after this log time
        self._generation = 0
        self._wake = threading.Event()
        self._thread: threading.Thread | None = None
        self._in_flight = 0
        self._flight_lock = threading.Condition()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._open_lock = asyncio.Lock()

    # -- files ------------------------------------------------------------------------------------------
    def resolve(self, name: str) -> Path:
        """A bare name is looked up in the recordings folder; a path is taken as it is, if inside the allowed
        folders (ReplayRefused otherwise, before anything tells whether the file exists)."""
        if self.allowed is not None:
            try:
                path = self.allowed.resolve(name)
            except FolderError as exc:
                raise ReplayRefused(str(exc)) from None
            if not path.is_file():
                raise LogNotFound(f"no log file {name!r}")
            return path
        path = Path(name).expanduser()
        if not path.is_absolute() and self.folder is not None and not path.exists():
            path = self.folder / path
        if not path.exists():
            raise LogNotFound(f"no log file {name!r}")
        return path

    async def open(self, name: str | Path) -> dict[str, Any]:
        """Opens a log (a progress figure runs while an unindexed file is scanned), paused at its start."""
        path = self.resolve(str(name))
        async with self._open_lock:
            await self.close()
            self._loop = asyncio.get_running_loop()
            self.state, self.progress, self.error, self._loading = "loading", 0.0, "", path
            try:
                reader = await asyncio.to_thread(LogSeriesReader, path, on_progress=self._on_progress)
                self.file = await asyncio.to_thread(ReplayFile, reader, path)
            except LogError as exc:
                self.state, self.error = "closed", str(exc)
                raise UnreadableLog(str(exc)) from exc
            finally:
                self._loading = None
            self.progress = 1.0
            self.position_ns = self._next_ns = self.file.start_ns
            self.delivered = self.skipped = 0
            self.state = "paused"
            self.running = True
            log.info("replay: %s opened (%.1f s, %d messages)", path, self.file.reader.duration,
                     self.file.reader.message_count)
            return self.file.info()

    def _on_progress(self, fraction: float) -> None:
        self.progress = max(0.0, min(1.0, fraction))

    async def close(self) -> None:
        self._halt()
        file, self.file = self.file, None
        if file is not None:
            await asyncio.to_thread(file.close)
        for robot in [r for r in self.hub.robots if keys.is_replayed(r)]:
            self.hub.forget(robot)  # the page drops a replayed robot the server no longer lists
        self.state = "closed"
        self.running = False

    # -- Source -----------------------------------------------------------------------------------------
    async def start(self) -> None:
        """Switching the source on plays the opened file."""
        self.play()

    async def stop(self) -> None:
        """Pauses (the file stays open, ``close()`` closes it)."""
        if self.state == "playing":
            self.pause()
        self.running = self.file is not None

    # -- the timeline -----------------------------------------------------------------------------------
    def _need_file(self) -> ReplayFile:
        if self.file is None:
            raise NoLogOpen("no log is open (POST /api/replay/open first)")
        return self.file

    def play(self) -> None:
        file = self._need_file()
        if self.state == "playing":
            return
        if self._next_ns > file.end_ns:  # played to the end: from the start again
            self._next_ns = self.position_ns = file.start_ns
        self._loop = asyncio.get_running_loop()
        self._halt()
        self.state = "playing"
        generation = self._generation
        self._thread = threading.Thread(target=self._play, args=(generation,), name="replay", daemon=True)
        self._thread.start()

    def pause(self) -> None:
        self._need_file()
        self._halt()
        self.state = "paused"

    def set_speed(self, speed: float) -> float:
        if not isinstance(speed, int | float) or not math.isfinite(speed) or not MIN_SPEED <= speed <= MAX_SPEED:
            raise BadTimelineRequest(f"speed must be between {MIN_SPEED} and {MAX_SPEED}, not {speed!r}")
        self.speed = float(speed)
        self._wake.set()  # the player re-anchors its clock
        return self.speed

    async def seek(self, t_s: float) -> dict[str, Any]:
        """Jumps to ``t_s`` seconds after the log's start; panels get each stream's state just before it."""
        file = self._need_file()
        if not isinstance(t_s, int | float) or not math.isfinite(t_s):
            raise BadTimelineRequest(f"seek needs a time in seconds, not {t_s!r}")
        target = file.start_ns + int(max(0.0, min(t_s, (file.end_ns - file.start_ns) / 1e9)) * 1e9)
        was_playing = self.state == "playing"
        self._halt()
        # the player is stopped now: say so, or play() below would see "playing" and not start it again
        self.state = "paused"
        self.position_ns = self._next_ns = target
        self.seeks += 1
        preview = await asyncio.to_thread(self._preview, file, target)
        self.hub.publish_many(preview)
        if was_playing:
            self.play()
        return self.status()

    def _preview(self, file: ReplayFile, target: int) -> list[HubMessage]:
        newest: dict[tuple[str, str], HubMessage] = {}
        for item in file.messages(max(file.start_ns, target - int(PREVIEW_S * 1e9)), target):
            msg = file.hub_message(item)
            if msg is not None:
                newest[(msg.robot, msg.topic)] = msg
        return sorted(newest.values(), key=lambda m: m.stamp)

    async def step(self, count: int = 1) -> dict[str, Any]:
        """Publishes the next ``count`` messages at once (paused afterwards)."""
        file = self._need_file()
        if self.state == "playing":
            self.pause()
        msgs = await asyncio.to_thread(self._next_messages, file, max(1, min(int(count), 10_000)))
        self.hub.publish_many(msgs)
        self.state = "ended" if not msgs else "paused"
        return self.status()

    def _next_messages(self, file: ReplayFile, count: int) -> list[HubMessage]:
        out: list[HubMessage] = []
        for item in file.messages(self._next_ns):
            self.position_ns, self._next_ns = item.log_time_ns, item.log_time_ns + 1
            msg = file.hub_message(item)
            if msg is None:
                self.skipped += 1
                continue
            out.append(msg)
            if len(out) >= count:
                break
        self.delivered += len(out)
        return out

    # -- the player thread ------------------------------------------------------------------------------
    def _halt(self) -> None:
        self._generation += 1
        self._wake.set()
        thread, self._thread = self._thread, None
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=5.0)

    def _play(self, generation: int) -> None:
        file = self.file
        if file is None:
            return
        speed = self.speed
        wall0, log0 = time.monotonic(), self._next_ns
        batch: list[HubMessage] = []
        batch_started = time.monotonic()
        try:
            for item in file.messages(self._next_ns):
                if self._generation != generation:
                    return
                while True:  # wait for the message's moment (speed changes re-anchor the clock)
                    if self.speed != speed:
                        speed, wall0, log0 = self.speed, time.monotonic(), self.position_ns
                    delay = wall0 + (item.log_time_ns - log0) / 1e9 / speed - time.monotonic()
                    if delay <= 0.001:
                        break
                    if batch:
                        self._deliver(batch, generation)
                        batch = []
                    self._wake.clear()
                    self._wake.wait(min(delay, 0.1))
                    if self._generation != generation:
                        return
                msg = file.hub_message(item)
                self.position_ns, self._next_ns = item.log_time_ns, item.log_time_ns + 1
                if msg is None:
                    self.skipped += 1
                    continue
                if not batch:
                    batch_started = time.monotonic()
                batch.append(msg)
                if len(batch) >= 1000 or time.monotonic() - batch_started >= BATCH_S:
                    self._deliver(batch, generation)
                    batch = []
            if batch:
                self._deliver(batch, generation)
            if self._generation == generation:
                self.state = "ended"
                self._next_ns = file.end_ns + 1
        except Exception as exc:  # a broken log ends the replay with a reason, never the server
            log.warning("replay stopped: %s", exc)
            self.error = str(exc)
            if self._generation == generation:
                self.state = "paused"

    def _deliver(self, batch: list[HubMessage], generation: int) -> None:
        """Hands a batch to the loop; waits while too many are still queued there (back-pressure)."""
        loop = self._loop
        if loop is None:
            return
        with self._flight_lock:
            while self._in_flight >= MAX_IN_FLIGHT and self._generation == generation:
                self._flight_lock.wait(0.1)
            self._in_flight += 1
        try:
            loop.call_soon_threadsafe(self._publish, batch, generation)
        except RuntimeError:  # the loop is closed: the server is going down
            with self._flight_lock:
                self._in_flight -= 1

    def _publish(self, batch: list[HubMessage], generation: int) -> None:
        with self._flight_lock:
            self._in_flight -= 1
            self._flight_lock.notify_all()
        if generation == self._generation:  # a seek or pause made this batch stale
            self.hub.publish_many(batch)
            self.delivered += len(batch)

    # -- what the UI shows ------------------------------------------------------------------------------
    def status(self) -> dict[str, Any]:
        status = super().status()
        file = self.file
        status.update(state=self.state, progress=round(self.progress, 4), speed=self.speed,
                      delivered=self.delivered, skipped=self.skipped,
                      path=str(file.path) if file else str(self._loading) if self._loading else None)
        if file is not None:
            status.update(position_s=max(0.0, (self.position_ns - file.start_ns) / 1e9),
                          duration_s=(file.end_ns - file.start_ns) / 1e9, position_ns=self.position_ns)
        return status

    def info(self) -> dict[str, Any]:
        return self._need_file().info()

    async def add_note(self, name: str, t_s: float | None = None) -> dict[str, Any]:
        """A named bookmark at ``t_s`` (default: the replay's position) in the log's sidecar, never in the log."""
        file = self._need_file()
        if t_s is None:
            at = self.position_ns
        elif isinstance(t_s, int | float) and math.isfinite(t_s):
            at = file.start_ns + int(max(0.0, min(t_s, (file.end_ns - file.start_ns) / 1e9)) * 1e9)
        else:
            raise BadTimelineRequest(f"a note needs a time in seconds, not {t_s!r}")
        note = await asyncio.to_thread(file.notes.add, name, max(file.start_ns, min(at, file.end_ns)))
        return file.mark(note, "note")

    async def shutdown(self) -> None:
        with contextlib.suppress(Exception):
            await self.close()
