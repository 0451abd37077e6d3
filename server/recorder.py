"""The server's recorder: manual recordings (UI, CLI) and automatic match recordings, split per half.

Both live in the server process, so recording goes on while no browser is open. A recording writes what
the hub sees (every source but replay) into ``recordings/*.mcap`` (server.recording.session). The match
recording follows the robots' ``gamestate``: it starts when the game leaves INITIAL, opens a new file per
half (overtime and penalty shoot-out get their own), stops at FINISHED, and bookmarks GameController
events (state changes, goals, penalties). Recording sends nothing to robots, so it is allowed in match mode.

A crash of the server does not end a recording: the journal (server.recording.journal) names what runs, and a
restarted server goes on with it in the next file of the same series (the match recording as soon as the robots'
gamestate says the game is still on).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from schemas.logs import LogError, LogReader, log_series
from server.config import RobotDescription
from server.hub import Hub, HubMessage, Subscriber
from server.recording.files import RecordingsFolder, safe_name, timestamped
from server.recording.game_events import GameEvent, GameEvents
from server.recording.journal import TOUCH_EVERY_S, ManualEntry, MatchEntry, RecordingJournal
from server.recording.scene import RecordedScene
from server.recording.session import HubRecording, RecordingStatus

log = logging.getLogger(__name__)

__all__ = ["GameEvents", "HubRecording", "Recorder", "RecorderError", "RecordingStatus"]

DEFAULT_ROTATE_BYTES = 512 << 20
GAP_BOOKMARK = "recording gap"


async def mark_gap(recording: HubRecording, cut_file: Path) -> None:
    """A bookmark on the resumed recording's timeline where a crash cut it off: from the last message the cut file
    kept to now (when this file starts), so replay shows the hole and how long it is."""
    resumed_ns = time.time_ns()

    def last_kept_ns() -> int | None:
        with LogReader(cut_file) as reader:  # a crash-cut file: its complete chunks
            return reader.end_ns if reader.message_count else None

    try:
        last_ns = await asyncio.to_thread(last_kept_ns)
    except (LogError, OSError) as exc:
        log.warning("the gap before %s not bookmarked: %s", recording.path.name, exc)
        return
    if last_ns is None or not recording.running:
        return
    gap_s = round(max(0.0, (resumed_ns - last_ns) / 1e9), 3)
    try:
        recording.bookmark(GAP_BOOKMARK, {"gap_s": gap_s, "from_ns": last_ns, "to_ns": resumed_ns,
                                          "cut_file": cut_file.name}, log_time_ns=last_ns + 1)
    except (LogError, OSError) as exc:
        log.warning("the gap before %s not bookmarked: %s", recording.path.name, exc)
        return
    log.warning("recording %s resumed after a gap of %.3f s", recording.path.name, gap_s)


class RecorderError(RuntimeError):
    """A recording cannot be started or stopped as asked; the text says why."""


class Recorder:
    """One manual recording at a time, plus the automatic match recording (independent of it)."""

    def __init__(self, hub: Hub, folder: Path, *, auto_match: bool = True,
                 rotate_bytes: int | None = DEFAULT_ROTATE_BYTES, chunk_size: int = 1 << 20,
                 description_for: Callable[[str], RobotDescription] | None = None) -> None:
        """description_for: where each robot's URDF is, for the /tf a recording carries (None: no /tf)."""
        self.hub = hub
        self.description_for = description_for
        self.folder = Path(folder)
        self.files = RecordingsFolder(self.folder)
        self.auto_match = auto_match
        self.rotate_bytes = rotate_bytes
        self.chunk_size = chunk_size
        self.manual: HubRecording | None = None
        self.match: HubRecording | None = None
        self.match_id = ""
        self.finished: list[RecordingStatus] = []
        self.events = GameEvents()
        self.journal = RecordingJournal(self.folder)
        self._game_sub: Subscriber | None = None
        self._game_task: asyncio.Task[None] | None = None
        self._journal_task: asyncio.Task[None] | None = None
        self._lock = asyncio.Lock()
        self._gap_tasks: set[asyncio.Task[None]] = set()

    # -- lifetime ---------------------------------------------------------------------------------------
    async def start(self) -> None:
        """Resumes what a crash cut off, starts watching the game (when auto_match); call on the server's loop."""
        if self._journal_task is not None:
            return
        await self._resume_interrupted()
        loop = asyncio.get_running_loop()
        self._journal_task = loop.create_task(self._keep_journal())
        if self.auto_match:
            self._game_sub = self.hub.subscribe("recorder:gamestate", maxlen=1000)
            self._game_sub.subscribe("*", "gamestate", replay_latest=False)
            self._game_task = loop.create_task(self._watch_game())

    async def _resume_interrupted(self) -> None:
        if not self.journal.acquire():
            return
        interrupted = self.journal.interrupted()
        match = interrupted.match if self.auto_match else None
        self.journal.set_match(match)  # pending until the first gamestate says whether the game is still on
        self.journal.set_manual(None)
        if match is not None:
            log.warning("the server stopped while recording match %s (%s): recording goes on if the game does",
                        match.match_id, match.part)
            self.match_id = safe_name(match.match_id)
            self.events.resume(match.part)
        if interrupted.manual is not None:
            await self._resume_manual(interrupted.manual)

    async def _resume_manual(self, entry: ManualEntry) -> None:
        path = self.folder / Path(entry.path).name  # the journal names a file, always one in this folder
        async with self._lock:
            try:
                self.manual = self._open(path, entry.reason, resume=True)
            except RecorderError as exc:
                log.error("interrupted recording %s not resumed: %s", path.name, exc)
                return
            self.journal.set_manual(ManualEntry(str(path), entry.reason))
            log.warning("the server stopped while recording %s: recording goes on in %s", path.name,
                        Path(self.manual.status.files[0]).name)

    async def _keep_journal(self) -> None:
        while True:
            await asyncio.sleep(TOUCH_EVERY_S)
            await asyncio.to_thread(self.journal.touch)

    async def close(self) -> None:
        for task in (self._game_task, self._journal_task):
            if task is not None:
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await task
        self._game_task = self._journal_task = None
        if self._game_sub is not None:
            self._game_sub.close()
        await self.stop_manual()
        await self._stop_match()
        self.journal.release()

    # -- manual -----------------------------------------------------------------------------------------
    async def start_manual(self, name: str = "", reason: str = "manual") -> RecordingStatus:
        async with self._lock:
            if self.manual is not None:
                raise RecorderError(f"already recording to {self.manual.path.name}")
            path = timestamped(self.folder, safe_name(name) if name else reason)
            self.manual = self._open(path, reason)
            self.journal.set_manual(ManualEntry(str(path), reason))
            log.info("recording to %s", path)
            return self.manual.status

    async def stop_manual(self) -> RecordingStatus | None:
        async with self._lock:
            recording, self.manual = self.manual, None
        if recording is None:
            return None
        self.journal.set_manual(None)
        status = await recording.stop()
        self.finished.append(status)
        log.info("recording %s stopped: %d messages", status.name, status.messages)
        return status

    def bookmark(self, name: str, data: dict[str, Any] | None = None) -> list[str]:
        """Marks now in every running recording; the names of the recordings marked."""
        marked = []
        refused = []
        for recording in (self.manual, self.match):
            if recording is not None:
                try:
                    recording.bookmark(name, data)
                except LogError as exc:  # the disk takes no data (the banner says so)
                    refused.append(f"{recording.path.name}: {exc}")
                    continue
                marked.append(recording.path.name)
        if refused and not marked:
            raise RecorderError("; ".join(refused))
        if not marked:
            raise RecorderError("nothing is being recorded")
        return marked

    async def mark(self, name: str, data: dict[str, Any] | None = None) -> list[str]:
        """``bookmark`` as the routers call it (the same for the recorder process, server.recorder_remote)."""
        return self.bookmark(name, data)

    # -- matches ----------------------------------------------------------------------------------------
    async def _watch_game(self) -> None:
        assert self._game_sub is not None
        while True:
            await self._game_sub.wait(timeout=1.0)
            for msg in self._game_sub.drain():
                if msg.source == "replay":
                    continue  # a replayed match is not a match being played
                await self.on_gamestate(msg)

    async def on_gamestate(self, msg: HubMessage) -> None:
        try:
            events = self.events.feed(msg.robot, msg.message)
        except Exception as exc:  # an undecodable or odd GameState must not end match recording
            log.warning("gamestate from %s ignored: %s", msg.robot, exc)
            return
        # one moment for the message's bookmarks, a nanosecond apart so a timeline keeps their order (goal, READY)
        when = int((msg.received + time.time() - time.monotonic()) * 1e9)
        for k, event in enumerate(events):
            await self._apply(event, when + k)

    async def _apply(self, event: GameEvent, when: int) -> None:
        if event.kind == "start":
            if not self.match_id or event.part == "half1":  # the second half keeps the first half's match id
                self.match_id = time.strftime("%Y%m%d-%H%M%S")
            await self._open_match_part(event.part)
        elif event.kind == "resume":
            await self._open_match_part(event.part, resume=True)
        elif event.kind == "split":
            await self._stop_match()
            await self._open_match_part(event.part)
        elif event.kind == "stop":
            await self._stop_match()
        elif event.kind == "bookmark" and self.match is not None:
            try:
                self.match.bookmark(event.name, event.data, log_time_ns=when)
            except LogError as exc:
                log.warning("bookmark %s not written: %s", event.name, exc)

    async def _open_match_part(self, part: str, resume: bool = False) -> None:
        """``resume``: after a crash, go on in the next file of the part's series (a new part starts its own)."""
        if self.match is not None:
            await self._stop_match()
        path = self.folder / f"match-{self.match_id}_{safe_name(part)}.mcap"
        if path.exists() and not resume:
            path = timestamped(self.folder, f"match-{self.match_id}_{part}")
        self.match = self._open(path, "match", resume=resume)
        self.journal.set_match(MatchEntry(self.match_id, part))
        log.info("match recording: %s", Path(self.match.status.files[0]).name)

    async def _stop_match(self) -> None:
        recording, self.match = self.match, None
        self.journal.set_match(None)
        if recording is not None:
            self.finished.append(await recording.stop())

    # -- shared -----------------------------------------------------------------------------------------
    def _open(self, path: Path, reason: str, resume: bool = False) -> HubRecording:
        before = log_series(path)[-1:] if resume else []  # the file the crash cut off
        try:
            scene = RecordedScene(self.description_for) if self.description_for is not None else None
            recording = HubRecording(self.hub, path, reason, rotate_bytes=self.rotate_bytes,
                                     chunk_size=self.chunk_size, resume=resume, scene=scene)
        except (LogError, OSError) as exc:
            raise RecorderError(f"cannot record to {path}: {exc}") from exc
        if before:
            self._gap_tasks.add(task := asyncio.get_running_loop().create_task(mark_gap(recording, before[0])))
            task.add_done_callback(self._gap_tasks.discard)
        return recording

    def active_paths(self) -> set[str]:
        return {f for r in (self.manual, self.match) if r is not None for f in r.status.files}

    def status(self) -> dict[str, Any]:
        return {"folder": str(self.folder), "auto_match": self.auto_match,
                "manual": self.manual.status.as_dict() if self.manual else None,
                "match": self.match.status.as_dict() if self.match else None,
                "recent": [s.as_dict() for s in self.finished[-10:]]}

    def listing(self) -> list[dict[str, Any]]:
        return self.files.listing(self.active_paths())
