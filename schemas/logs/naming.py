"""How pitchside names things inside an MCAP log: channel topics, rotated files, bookmarks."""

from __future__ import annotations

import re
from pathlib import Path

BOOKMARK_TOPIC = "pitchside/bookmarks"
BOOKMARK_TYPE = "std_msgs/msg/String"
BOOKMARK_METADATA_NAME = "bookmark"


class LogError(Exception):
    """A log cannot be written or opened (bad arguments, not an MCAP file, closed log)."""


def channel_topic(robot_id: str, topic: str) -> str:
    """MCAP channel topic of a robot's topic: ``/<robot_id>/<topic>`` (``/<topic>`` without a robot)."""
    return f"/{robot_id}/{topic}" if robot_id else f"/{topic}"


def split_channel(mcap_topic: str, metadata: dict[str, str]) -> tuple[str, str]:
    """(robot_id, topic) of a channel: from our metadata, else robot "" and the name without its slash."""
    if "robot_id" in metadata and "topic" in metadata:
        return metadata["robot_id"], metadata["topic"]
    return "", mcap_topic.lstrip("/")


def full_typename(name: str) -> str:
    """``pkg/Type`` (legacy schema names) -> ``pkg/msg/Type``."""
    parts = name.split("/")
    return f"{parts[0]}/msg/{parts[1]}" if len(parts) == 2 else name


def rotated_path(path: Path, index: int) -> Path:
    """File ``index`` of a rotated log: the path itself, then ``<stem>_001.mcap``, ``<stem>_002.mcap`` ..."""
    return path if index == 0 else path.with_name(f"{path.stem}_{index:03d}{path.suffix or '.mcap'}")


def _numbered(path: Path) -> list[tuple[int, Path]]:
    pattern = re.compile(re.escape(path.stem) + r"_(\d{3,})" + re.escape(path.suffix or ".mcap") + "$")
    return sorted((int(m.group(1)), p) for p in path.parent.glob(f"{path.stem}_*") if (m := pattern.match(p.name)))


def log_series(path: str | Path) -> list[Path]:
    """The files of a rotated log in order, starting with ``path`` itself (if it exists)."""
    path = Path(path)
    return ([path] if path.exists() else []) + [p for _, p in _numbered(path)]


def next_series_index(path: str | Path) -> int:
    """The index (for ``rotated_path``) after the last file of the series on disk; 0 when there is none."""
    path = Path(path)
    numbered = _numbered(path)
    if numbered:
        return numbered[-1][0] + 1
    return 1 if path.exists() else 0
