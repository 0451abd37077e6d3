"""The animation files a robot can play, found by their ``name`` field or file name, reloaded when they change."""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from wire.animation.animation_file import Animation, AnimationError, load_animation


@dataclass(frozen=True)
class AnimationEntry:
    """One file: its animation, or the error that keeps it from loading."""

    path: Path
    stamp: tuple[int, int]  # (mtime_ns, size): a change of either means reload
    animation: Animation | None
    error: AnimationError | None

    @property
    def source(self) -> str:
        return self.path.name


class AnimationLibrary:
    """Indexes ``*.json`` under some folders (sub-folders like ``standup/`` are only organisation).

    A folder that does not exist (yet) is simply empty. The first folder wins when two files share
    a name; the clash is listed in ``problems``.
    """

    def __init__(self, folders: Iterable[Path] = ()) -> None:
        self.folders = [Path(f) for f in folders]
        self.problems: list[str] = []
        self._entries: dict[Path, AnimationEntry] = {}
        self._by_name: dict[str, AnimationEntry] = {}
        self._by_stem: dict[str, AnimationEntry] = {}
        self._signature: tuple[tuple[str, int, int], ...] | None = None

    def set_folders(self, folders: Iterable[Path]) -> None:
        self.folders = [Path(f) for f in folders]
        self._signature = None

    def _scan(self) -> list[tuple[Path, tuple[int, int]]]:
        found = []
        for folder in self.folders:
            if not folder.is_dir():
                continue
            for root, dirs, files in os.walk(folder):
                dirs.sort()
                for name in sorted(files):
                    if name.endswith(".json") and not name.startswith("."):
                        path = Path(root) / name
                        try:
                            st = path.stat()
                        except OSError:
                            continue  # deleted while we looked
                        found.append((path, (st.st_mtime_ns, st.st_size)))
        return found

    def refresh(self) -> bool:
        """Re-reads changed, new and removed files (one stat per file when nothing changed); True if anything did."""
        found = self._scan()
        signature = tuple((str(p), *stamp) for p, stamp in found)
        if signature == self._signature:
            return False
        self._signature = signature
        entries: dict[Path, AnimationEntry] = {}
        for path, stamp in found:
            old = self._entries.get(path)
            if old is not None and old.stamp == stamp:
                entries[path] = old
                continue
            try:
                entries[path] = AnimationEntry(path, stamp, load_animation(path), None)
            except AnimationError as exc:
                entries[path] = AnimationEntry(path, stamp, None, exc)
        self._entries = entries
        self._by_name, self._by_stem, self.problems = {}, {}, []
        for entry in entries.values():
            self._by_stem.setdefault(entry.path.stem, entry)
            if entry.error is not None:
                self.problems.append(str(entry.error))
            if entry.animation is None:
                continue
            first = self._by_name.setdefault(entry.animation.name, entry)
            if first is not entry:
                self.problems.append(f"{entry.source}: animation name {entry.animation.name!r} already used by "
                                     f"{first.path}; this file is reachable by its file name only")
        return True

    def names(self) -> list[str]:
        return sorted(self._by_name)

    def entries(self) -> list[AnimationEntry]:
        return list(self._entries.values())

    def find(self, name: str) -> tuple[Animation, str]:
        """(animation, file name) by animation name, else by file name (with or without .json)."""
        entry = self._by_name.get(name) or self._by_stem.get(name.removesuffix(".json"))
        if entry is None:
            where = ", ".join(str(f) for f in self.folders) or "no folders"
            raise AnimationError(name, f"no animation with this name or file name (searched {where})")
        if entry.error is not None:
            raise entry.error
        assert entry.animation is not None
        return entry.animation, entry.source
