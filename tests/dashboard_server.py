"""Test helper: the dashboard server as a real subprocess (``python -m server``) on a free loopback port."""

from __future__ import annotations

import contextlib
import functools
import os
import secrets
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import httpx

from tests.support import REPO, free_port
from tests.waiting import wait_for


@dataclass
class RunningServer:
    process: subprocess.Popen[bytes]
    port: int
    log: Path
    token: str = ""

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    @property
    def login_url(self) -> str:
        """The page as the printed link opens it: the browser gets the session cookie and may control."""
        return f"{self.url}/?token={self.token}"

    def page_url(self, preset: str) -> str:
        """The signing-in link opening the page in a layout preset ("match", "lab", "replay", or "all": every
        panel, the page scrolling, the arrangement the older browser tests were written for)."""
        return f"{self.login_url}&preset={preset}"

    @property
    def auth(self) -> dict[str, str]:
        return {"Authorization": f"Bearer {self.token}"}

    @functools.cached_property
    def http(self) -> httpx.Client:
        """An HTTP client that shows the token, as a script or the CLI does."""
        return httpx.Client(headers=self.auth, timeout=30.0)

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
def dashboard_server(args: list[str], log_dir: Path, host: str = "127.0.0.1", port: int | None = None
                     ) -> Iterator[RunningServer]:
    """Starts the server with ``args`` (plus --host/--port: ``port`` or a free one) and stops it with SIGTERM
    afterwards."""
    port = port or free_port()
    log = log_dir / f"server-{port}.log"
    token = secrets.token_urlsafe(12)
    env = dict(os.environ, PYTHONUNBUFFERED="1", PITCHSIDE_TOKEN=token)
    with log.open("wb") as out:
        process = subprocess.Popen([sys.executable, "-m", "server", "--host", host, "--port", str(port), *args],
                                   cwd=REPO, stdout=out, stderr=subprocess.STDOUT, env=env)
    running = RunningServer(process, port, log, token)
    try:
        wait_for(lambda: _up(running.url, process, log), timeout=60.0, interval=0.1, what="dashboard server up")
        yield running
    finally:
        if "http" in running.__dict__:
            running.http.close()
        process.terminate()
        try:
            process.wait(10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(5)
