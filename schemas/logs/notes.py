"""Notes on a log: bookmarks a person adds while looking at a replay, kept in a sidecar file beside the log.

A log is evidence: what the robots saw and did. Notes added afterwards ("kick too short", "fell here") must never
change it, and an MCAP file cannot take a record after its summary without being rewritten. So notes live in
``<first file of the log>.notes.json`` beside it (one file for a half rotated into several), read together with
the log's own bookmarks, and written atomically (a crash mid-write leaves the old notes, never half new ones).
A sidecar that cannot be read is reported and treated as empty; it is only overwritten by a new note.
"""

from __future__ import annotations

import contextlib
import json
import os
import time
from pathlib import Path
from typing import Any

from schemas.logs.naming import LogError
from schemas.logs.reader import Bookmark

NOTES_SUFFIX = ".notes.json"
NOTES_FORMAT = "pitchside-log-notes"
MAX_NOTES = 1000  # per log: a sidecar stays small enough to read at every open
MAX_NAME_CHARS = 120


class NotesError(LogError):
    """A note that cannot be added: a bad name, too many notes, or a sidecar that cannot be written."""


def notes_path(log_path: Path) -> Path:
    """The sidecar of a log (of its first file, for a rotated series)."""
    return log_path.with_name(log_path.name + NOTES_SUFFIX)


def clean_name(name: str) -> str:
    """The note's name as stored: one line, trimmed; NotesError if nothing is left or it is too long."""
    text = " ".join(str(name).split())
    if not text:
        raise NotesError("a note needs a name")
    if len(text) > MAX_NAME_CHARS:
        raise NotesError(f"a note's name has at most {MAX_NAME_CHARS} characters, not {len(text)}")
    return text


class LogNotes:
    """The notes of one log; ``problem`` says why an existing sidecar was not read ("" if it was, or is absent)."""

    def __init__(self, log_path: Path) -> None:
        self.path = notes_path(Path(log_path))
        self.problem = ""
        self.notes: list[Bookmark] = self._read()

    def _read(self) -> list[Bookmark]:
        try:
            data = json.loads(self.path.read_text())
        except FileNotFoundError:
            return []
        except (OSError, ValueError) as exc:
            self.problem = f"{self.path.name} unreadable: {exc}"
            return []
        try:
            if data.get("format") != NOTES_FORMAT:
                raise ValueError(f"not a {NOTES_FORMAT} file")
            notes = [Bookmark(clean_name(n["name"]), int(n["log_time_ns"]), {"note": True, "added": float(n.get(
                "added", 0.0))}) for n in data["notes"][:MAX_NOTES]]
        except (AttributeError, KeyError, TypeError, ValueError, NotesError) as exc:
            self.problem = f"{self.path.name} unreadable: {exc}"
            return []
        return sorted(notes, key=lambda b: (b.log_time_ns, b.name))

    def add(self, name: str, log_time_ns: int) -> Bookmark:
        """Adds a note at ``log_time_ns`` and writes the sidecar; NotesError if it cannot be written."""
        if len(self.notes) >= MAX_NOTES:
            raise NotesError(f"this log has {MAX_NOTES} notes already")
        note = Bookmark(clean_name(name), int(log_time_ns), {"note": True, "added": time.time()})
        notes = sorted([*self.notes, note], key=lambda b: (b.log_time_ns, b.name))
        self._write(notes)
        self.notes, self.problem = notes, ""
        return note

    def _write(self, notes: list[Bookmark]) -> None:
        body: dict[str, Any] = {"format": NOTES_FORMAT, "log": self.path.name.removesuffix(NOTES_SUFFIX),
                                "notes": [{"name": n.name, "log_time_ns": n.log_time_ns, "added": n.data["added"]}
                                          for n in notes]}
        partial = self.path.with_name(self.path.name + ".partial")
        try:
            partial.write_text(json.dumps(body, indent=1))
            os.replace(partial, self.path)
        except OSError as exc:
            with contextlib.suppress(OSError):
                partial.unlink(missing_ok=True)
            raise NotesError(f"notes not written beside the log ({self.path}): {exc.strerror or exc}") from exc
