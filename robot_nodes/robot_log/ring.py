"""The robot's log folder as a bounded ring: whole halves dropped, oldest first, so the robot's disk never fills.

A robot records every topic at full rate during a match; over a tournament that is more than its disk holds. The
folder has a size cap, and the disk keeps a margin free besides: when either is passed, the files of the oldest half
go first (a half is every file whose name has the same ``<robot>_<part>_<start>`` stem before the rotation index);
the half being written is never dropped, only its finished files could be if it alone passes the cap.
"""

from __future__ import annotations

import logging
import re
import shutil
from pathlib import Path

log = logging.getLogger(__name__)

_ROTATED = re.compile(r"_\d{3,}$")


def half_of(path: Path) -> str:
    """The half a file belongs to: its stem without the rotation index (``robot1_half1_20260101-120000``)."""
    return _ROTATED.sub("", path.stem)


def log_files(folder: Path) -> list[Path]:
    """The folder's logs, oldest first (by modification time, then name: a half's files in order)."""
    if not folder.is_dir():
        return []
    return sorted(folder.glob("*.mcap"), key=lambda p: (p.stat().st_mtime, p.name))


def enforce(folder: Path, cap_bytes: int, keep_free_bytes: int, writing: Path | None = None) -> list[Path]:
    """Drops the oldest halves until the folder is within ``cap_bytes`` and the disk has ``keep_free_bytes``
    free; never the file being written. Returns what was dropped."""
    dropped: list[Path] = []
    while True:
        files = [p for p in log_files(folder) if p != writing]
        total = sum(p.stat().st_size for p in files) + (writing.stat().st_size if writing and writing.exists() else 0)
        free = shutil.disk_usage(folder).free
        if (total <= cap_bytes and free >= keep_free_bytes) or not files:
            return dropped
        oldest = half_of(files[0])
        current = half_of(writing) if writing is not None else None
        victims = [p for p in files if half_of(p) == oldest]
        if oldest == current:  # only the current half's finished files are left: the oldest of them
            victims = victims[:1]
        for path in victims:
            log.warning("robot log ring full (cap %d bytes, %d free): dropping %s", cap_bytes, free, path.name)
            path.unlink(missing_ok=True)
            dropped.append(path)
