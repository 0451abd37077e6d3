"""The recordings folder: file names for new recordings and the listing (size, duration) the UI shows."""

from __future__ import annotations

import json
import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from schemas.logs import LogError, LogReader, data_start_ns
from server.security import AllowedFolders, FolderError

_SAFE = re.compile(r"[^A-Za-z0-9_.-]+")


def safe_name(name: str) -> str:
    """A file stem made of letters, digits, ``_.-`` only (a name from the UI never leaves the folder)."""
    cleaned = _SAFE.sub("_", name).strip("._")
    return cleaned[:80] or "recording"


def timestamped(folder: Path, label: str) -> Path:
    """``<folder>/<YYYYmmdd-HHMMSS>_<label>.mcap``, never an existing file."""
    base = f"{time.strftime('%Y%m%d-%H%M%S')}_{safe_name(label)}"
    path = folder / f"{base}.mcap"
    n = 1
    while path.exists():
        path = folder / f"{base}-{n}.mcap"
        n += 1
    return path


def pulled_robots(path: Path) -> list[str] | None:
    """The robots whose own logs `pitchside logs pull` merged into this match log's half (its ``.pulled.json``)."""
    record = path.with_name(path.stem + ".pulled.json")
    if not record.is_file():
        return None
    try:
        return sorted(json.loads(record.read_text()).get("robots", {}))
    except (OSError, ValueError, AttributeError):
        return None


@dataclass(slots=True)
class _Cached:
    key: tuple[int, int]
    info: dict[str, Any]


class RecordingsFolder:
    """Lists ``*.mcap`` of the folder; a file's duration and counts come from its index (cached by size/mtime)."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self._cache: dict[Path, _Cached] = {}

    def resolve(self, name: str) -> Path:
        """The file ``name`` (a bare file name) inside the folder; LogError if it is not there. Through the
        server's one check of client paths, so a link in the folder that points out of it leads nowhere."""
        try:
            path = AllowedFolders([self.folder], "recordings").resolve(Path(name).name)
        except FolderError:
            path = None
        if path is None or path.suffix != ".mcap" or not path.is_file():
            raise LogError(f"no recording {name!r} in {self.folder}")
        return path

    def listing(self, active: set[str]) -> list[dict[str, Any]]:
        """Newest first. Files being written are listed with their size only (their index comes at the end)."""
        if not self.folder.is_dir():
            return []
        out = []
        for path in sorted(self.folder.glob("*.mcap"), key=lambda p: p.stat().st_mtime, reverse=True):
            stat = path.stat()
            entry: dict[str, Any] = {"name": path.name, "size_bytes": stat.st_size, "modified": stat.st_mtime,
                                     "recording": str(path) in active}
            if not entry["recording"]:
                entry.update(self._summary(path, (stat.st_size, stat.st_mtime_ns)))
            pulled = pulled_robots(path)
            if pulled is not None:
                entry["pulled"] = pulled
            out.append(entry)
        return out

    def _summary(self, path: Path, key: tuple[int, int]) -> dict[str, Any]:
        cached = self._cache.get(path)
        if cached is not None and cached.key == key:
            return cached.info
        try:
            with LogReader(path) as reader:
                # as long as replay's timeline: from the real data on, not from stale opening messages
                duration = (reader.end_ns - data_start_ns(reader)) / 1e9 if reader.message_count else 0.0
                info: dict[str, Any] = {"duration_s": round(duration, 3), "messages": reader.message_count,
                                        "robots": [r for r in reader.robots if r], "indexed": reader.indexed,
                                        "bookmarks": len(reader.bookmarks)}
        except LogError as exc:
            info = {"error": str(exc)}
        self._cache[path] = _Cached(key, info)
        return info
