"""Test helper: the dashboard server as a real subprocess (``python -m server``) on a free loopback port."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import httpx

from tests.conftest import REPO, free_port
from tests.waiting import wait_for


@dataclass
class RunningServer:
    process: subprocess.Popen[bytes]
    port: int
    log: Path

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    @property
    def ws_url(self) -> str:
        return f"ws://127.0.0.1:{self.port}/ws"

    def output(self) -> str:
        return self.log.read_text(errors="replace")


def _up(url: str, process: subprocess.Popen[bytes], log: Path) -> bool:
    if process.poll() is not None:
        raise AssertionError(f"server exited with {process.returncode}:\n{log.read_text(errors='replace')}")
    try:
        return httpx.get(f"{url}/api/config", timeout=1.0).status_code == 200
    except httpx.HTTPError:
        return False


@contextlib.contextmanager
def dashboard_server(args: list[str], log_dir: Path, host: str = "127.0.0.1") -> Iterator[RunningServer]:
    """Starts the server with ``args`` (plus --host/--port) and stops it with SIGTERM afterwards."""
    port = free_port()
    log = log_dir / f"server-{port}.log"
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    with log.open("wb") as out:
        process = subprocess.Popen([sys.executable, "-m", "server", "--host", host, "--port", str(port), *args],
                                   cwd=REPO, stdout=out, stderr=subprocess.STDOUT, env=env)
    running = RunningServer(process, port, log)
    try:
        wait_for(lambda: _up(running.url, process, log), timeout=60.0, interval=0.1, what="dashboard server up")
        yield running
    finally:
        process.terminate()
        try:
            process.wait(10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(5)
