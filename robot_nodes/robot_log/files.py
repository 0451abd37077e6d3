"""The robot's log files over the bus, for ``pitchside logs pull`` in the lab: a listing and the files in pieces.

Keys (Zenoh queries in the robot's namespace of the domain, wire.keys.robot_log_key; answered only when asked: in a
match nobody asks, and the robot's bus connects to nobody): ``.../_robot_log/list`` answers JSON
``[{"name", "size_bytes", "writing"}]``; ``.../_robot_log/file`` with the query payload JSON
``{"name", "offset", "length"}`` answers those bytes of that file (at most PIECE_BYTES; a name is a bare file name
of the folder, nothing else is served).
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable
from pathlib import Path

import zenoh

from wire import keys

log = logging.getLogger(__name__)

PIECE_BYTES = 4 << 20


def list_key(robot: str) -> str:
    return keys.robot_log_key(robot, "list")


def file_key(robot: str) -> str:
    return keys.robot_log_key(robot, "file")


class LogFileServer:
    """Answers the two queries for ``folder``; ``writing()`` names the files still being written."""

    def __init__(self, session: zenoh.Session, robot: str, folder: Path,
                 writing: Callable[[], set[Path]] = set) -> None:
        self.folder = folder
        self.robot = robot
        self.writing = writing
        self._queryables = [session.declare_queryable(list_key(robot), self._list),
                            session.declare_queryable(file_key(robot), self._piece)]

    def _list(self, query: zenoh.Query) -> None:
        writing = {p.name for p in self.writing()}
        files = sorted(self.folder.glob("*.mcap")) if self.folder.is_dir() else []
        listing = [{"name": p.name, "size_bytes": p.stat().st_size, "writing": p.name in writing} for p in files]
        query.reply(list_key(self.robot), json.dumps(listing).encode())

    def _piece(self, query: zenoh.Query) -> None:
        try:
            asked = json.loads(query.payload.to_bytes() if query.payload is not None else b"{}")
            name, offset = str(asked["name"]), int(asked.get("offset", 0))
            length = min(int(asked.get("length", PIECE_BYTES)), PIECE_BYTES)
            path = self.folder / Path(name).name
            if Path(name).name != name or path.suffix != ".mcap" or not path.is_file() or offset < 0 or length < 0:
                raise ValueError(f"no log {name!r} on {self.robot}")
            with path.open("rb") as file:
                file.seek(offset)
                data = file.read(length)
            query.reply(file_key(self.robot), data)
        except (ValueError, KeyError, TypeError, OSError) as exc:  # a bad request is answered, never fatal
            query.reply_err(f"{type(exc).__name__}: {exc}")

    def close(self) -> None:
        for queryable in self._queryables:
            queryable.undeclare()
