"""Test helper: the recorder process (``python -m server.recording``) and its control API, as the dashboard uses it."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx

from tests.support import REPO


@contextlib.contextmanager
def recorder_processes(args: list[str], log_dir: Path, copies: int = 1) -> Iterator[list[subprocess.Popen[bytes]]]:
    """``copies`` recorder processes with the same arguments (one serves, the others wait as spares)."""
    processes = []
    try:
        for n in range(copies):
            with (log_dir / f"recorder-{n}.log").open("wb") as out:
                processes.append(subprocess.Popen([sys.executable, "-m", "server.recording", *args], cwd=REPO,
                                                  stdout=out, stderr=subprocess.STDOUT,
                                                  env=dict(os.environ, PYTHONUNBUFFERED="1")))
        yield processes
    finally:
        for process in processes:
            process.terminate()
        for process in processes:
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait(5)


def control(port: int, token: str, path: str = "/status", method: str = "GET") -> Any:
    return httpx.request(method, f"http://127.0.0.1:{port}{path}", headers={"Authorization": f"Bearer {token}"},
                         timeout=5).json()


def answers(port: int, token: str) -> dict[str, Any] | None:
    try:
        return dict(control(port, token))
    except httpx.HTTPError:
        return None
