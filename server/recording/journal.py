"""The recording journal: what the server is recording, kept beside the files, so a crash does not end a recording.

A team starts a recording (or the match starts one) and looks at the game; when the server dies and its supervisor
restarts it, the recording has to go on by itself. The journal (``.recording.json`` in the recordings folder) holds
the running manual recording (its file and reason) and the running match recording (match id and part). It is
rewritten atomically on every start and stop, so a clean stop leaves nothing behind, and touched while recording,
so a journal that went quiet long ago (a laptop switched off mid-recording yesterday) is not resumed. One server
owns a folder's journal at a time (an advisory lock the kernel drops when the process dies): a second dashboard on
the same folder, e.g. ``pitchside replay`` beside a running match, never takes over the first one's recordings.
"""

from __future__ import annotations

import fcntl
import json
import logging
import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)

JOURNAL_NAME = ".recording.json"
LOCK_NAME = ".recording.lock"
RESUME_WITHIN_S = 300.0  # a recording cut off longer ago than this is over, not interrupted
TOUCH_EVERY_S = 10.0  # while recording; far below RESUME_WITHIN_S


@dataclass(frozen=True, slots=True)
class ManualEntry:
    """A manual recording: its first file (a resumed recording continues that file's series) and why it runs."""

    path: str
    reason: str


@dataclass(frozen=True, slots=True)
class MatchEntry:
    """The automatic match recording: the match it belongs to and the part (half1, half2, ...) being recorded."""

    match_id: str
    part: str


@dataclass(frozen=True, slots=True)
class Interrupted:
    """What was being recorded when the server stopped without stopping its recordings."""

    manual: ManualEntry | None = None
    match: MatchEntry | None = None


class RecordingJournal:
    """Reads and writes the journal of one recordings folder once ``acquire`` made this process its owner (until
    then, or when another live server owns it, the journal is left alone). A journal that cannot be written is
    logged, never fatal: the recording itself goes on."""

    def __init__(self, folder: Path) -> None:
        self.path = folder / JOURNAL_NAME
        self._lock_path = folder / LOCK_NAME
        self._lock_fd: int | None = None
        self._manual: ManualEntry | None = None
        self._match: MatchEntry | None = None

    def acquire(self) -> bool:
        """Makes this process the journal's owner; False when another running server owns it."""
        if self._lock_fd is not None:
            return True
        try:
            self._lock_path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(self._lock_path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            log.warning("recording journal lock %s not opened (recordings will not resume after a crash): %s",
                        self._lock_path, exc)
            return False
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            log.info("another server records into %s: its recordings are its own to resume after a crash",
                     self._lock_path.parent)
            return False
        self._lock_fd = fd
        return True

    def release(self) -> None:
        if self._lock_fd is not None:
            os.close(self._lock_fd)  # closing drops the lock
            self._lock_fd = None

    @property
    def owned(self) -> bool:
        return self._lock_fd is not None

    def interrupted(self) -> Interrupted:
        """What a crash cut off (nothing after a clean stop, when the journal is too old or unreadable, or when
        this process does not own it)."""
        if not self.owned:
            return Interrupted()
        try:
            age = time.time() - self.path.stat().st_mtime
            data = json.loads(self.path.read_text())
            manual = ManualEntry(**data["manual"]) if data.get("manual") else None
            match = MatchEntry(**data["match"]) if data.get("match") else None
        except FileNotFoundError:
            return Interrupted()
        except (OSError, ValueError, TypeError, KeyError, AttributeError) as exc:
            log.warning("recording journal %s unreadable, nothing resumed: %s", self.path, exc)
            return Interrupted()
        if age > RESUME_WITHIN_S:
            log.warning("recording journal %s is %.0f s old: the recordings it names are not resumed", self.path, age)
            return Interrupted()
        return Interrupted(manual, match)

    def set_manual(self, entry: ManualEntry | None) -> None:
        self._manual = entry
        self._write()

    def set_match(self, entry: MatchEntry | None) -> None:
        self._match = entry
        self._write()

    def touch(self) -> None:
        """Says the recordings it names are still running."""
        if self.owned and (self._manual is not None or self._match is not None):
            try:
                os.utime(self.path)
            except OSError as exc:
                log.warning("recording journal %s not touched: %s", self.path, exc)

    def _write(self) -> None:
        if not self.owned:
            return
        state: dict[str, Any] = {"manual": asdict(self._manual) if self._manual else None,
                                 "match": asdict(self._match) if self._match else None}
        try:
            if self._manual is None and self._match is None:
                self.path.unlink(missing_ok=True)
                return
            self.path.parent.mkdir(parents=True, exist_ok=True)
            partial = self.path.with_name(self.path.name + ".partial")
            partial.write_text(json.dumps(state))
            os.replace(partial, self.path)  # a crash mid-write leaves the old journal, never half a new one
        except OSError as exc:
            log.warning("recording journal %s not written (a crash would end the recordings): %s", self.path, exc)
