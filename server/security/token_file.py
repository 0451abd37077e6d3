"""Where a running dashboard leaves its token for the command line of the same user (``pitchside record``).

One small JSON file per server (``server-<port>.json``: url, token, pid) in a folder only this user can enter:
``$XDG_RUNTIME_DIR/pitchside`` or, without it, ``<tmp>/pitchside-<uid>``. A folder that another user owns or
can write to is refused, so nobody can plant a file there or read one.
"""

from __future__ import annotations

import contextlib
import json
import os
import stat
import tempfile
from pathlib import Path
from typing import Any


class TokenFileError(OSError):
    """The runtime folder is not safe to keep a token in."""


def runtime_dir() -> Path:
    base = os.environ.get("XDG_RUNTIME_DIR")
    return Path(base) / "pitchside" if base else Path(tempfile.gettempdir()) / f"pitchside-{os.getuid()}"


def _safe_dir() -> Path:
    folder = runtime_dir()
    folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    info = folder.lstat()
    if not stat.S_ISDIR(info.st_mode) or info.st_uid != os.getuid() or info.st_mode & 0o077:
        raise TokenFileError(f"{folder} is not a folder that only this user can use; remove it and start again")
    return folder


def token_path(port: int) -> Path:
    return runtime_dir() / f"server-{port}.json"


def write_token_file(port: int, url: str, token: str) -> Path:
    """The file for this server (replacing one a previous server on the port left behind); the files of servers that
    are gone (killed: they had no chance to remove theirs) go too, so the folder does not fill up."""
    folder = _safe_dir()
    for left in folder.glob("server-*.json"):
        with contextlib.suppress(OSError, ValueError):
            if not _running(json.loads(left.read_text()).get("pid")):
                left.unlink()
    path = folder / f"server-{port}.json"
    temp = path.with_suffix(".tmp")
    with contextlib.suppress(FileNotFoundError):
        temp.unlink()
    fd = os.open(temp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "w") as out:
        json.dump({"url": url, "token": token, "pid": os.getpid()}, out)
    temp.replace(path)
    return path


def read_token_file(port: int) -> dict[str, Any] | None:
    """What the server on this port left, or None (no file, unsafe folder, a server that is gone)."""
    try:
        path = _safe_dir() / f"server-{port}.json"
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or not isinstance(data.get("token"), str) or not _running(data.get("pid")):
        return None
    return data


def _running(pid: Any) -> bool:
    """Whether a process with this pid runs (one of another user counts: it exists)."""
    if not isinstance(pid, int) or pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def remove_token_file(port: int) -> None:
    with contextlib.suppress(OSError):
        data = read_token_file(port)
        if data is not None and data.get("pid") == os.getpid():
            token_path(port).unlink()
