"""Test and bench helper: `pitchside demo` (or `match`) as a real subprocess tree, and a WebSocket observer of its
dashboard."""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx
import psutil

from server.protocol import unbatch
from tests.support import REPO, free_port
from tests.waiting import wait_for

BANNER = re.compile(r"open (http://127\.0\.0\.1:\d+)/\?token=(\S+)")


@dataclass
class RunningDemo:
    process: subprocess.Popen[bytes]
    url: str
    log: Path
    token: str = ""

    @property
    def login_url(self) -> str:
        """The link the demo prints: opening it signs the browser in (session cookie), so it may control."""
        return f"{self.url}/?token={self.token}"

    def page_url(self, preset: str) -> str:
        """The signing-in link opening the page in a layout preset ("match", "lab", "replay", or "all": every
        panel, the page scrolling, the arrangement the older browser tests were written for)."""
        return f"{self.login_url}&preset={preset}"

    @property
    def auth(self) -> dict[str, str]:
        return {"Authorization": f"Bearer {self.token}"}

    @property
    def ws_url(self) -> str:
        return self.url.replace("http://", "ws://") + "/ws"

    def output(self) -> str:
        return self.log.read_text(errors="replace")

    def processes(self) -> list[psutil.Process]:
        """The demo and every process it started (world, nodes, GameController, server)."""
        root = psutil.Process(self.process.pid)
        return [root, *root.children(recursive=True)]


def _up(process: subprocess.Popen[bytes], log: Path) -> tuple[str, str] | None:
    """(url, token) once the printed dashboard answers."""
    if process.poll() is not None:
        raise AssertionError(f"{log.stem} exited with {process.returncode}:\n{log.read_text(errors='replace')}")
    match = BANNER.search(log.read_text(errors="replace"))
    if match is None:
        return None
    try:
        up = httpx.get(f"{match.group(1)}/api/config", timeout=1.0).status_code == 200
    except httpx.HTTPError:
        return None
    return (match.group(1), match.group(2)) if up else None


@contextlib.contextmanager
def running_demo(log_dir: Path, *args: str, program: list[str] | None = None, cwd: Path = REPO,
                 command: str = "demo", up_timeout_s: float = 90.0) -> Iterator[RunningDemo]:
    """`pitchside demo --port <free> *args` (by default `python -m pitchside.cli` of this checkout; an installed
    program and another folder for the wheel), stopped with SIGTERM (its launcher stops the rest). ``command``:
    "match" runs `pitchside match` the same way."""
    log = log_dir / f"{command}.log"
    env = {k: v for k, v in os.environ.items() if program is None or k != "PYTHONPATH"}
    env.update(PYTHONUNBUFFERED="1", MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    program_words = program or [sys.executable, "-m", "pitchside.cli"]
    with log.open("wb") as out:
        process = subprocess.Popen([*program_words, command, "--port", str(free_port()), *args],
                                   cwd=cwd, stdout=out, stderr=subprocess.STDOUT, env=env, start_new_session=True)
    try:
        found = wait_for(lambda: _up(process, log), timeout=up_timeout_s, interval=0.2, what=f"{command} dashboard up")
        assert found is not None  # wait_for returns only a truthy value
        yield RunningDemo(process, found[0], log, found[1])
    finally:
        process.send_signal(signal.SIGTERM)
        try:
            process.wait(20)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, signal.SIGKILL)
            process.wait(5)


@dataclass
class DashboardObserver:
    """An independent /ws client: the latest frame per (robot, topic) and every world real-time-factor report."""

    ws_url: str
    topics: tuple[str, ...]
    max_hz: float = 0.0  # per stream; 0: every message
    latest: dict[tuple[str, str], dict[str, Any]] = field(default_factory=dict)
    real_time_factors: list[tuple[float, float]] = field(default_factory=list)  # (wall time, factor)
    error: str = ""
    _stop: threading.Event = field(default_factory=threading.Event)
    _thread: threading.Thread | None = None

    def __enter__(self) -> DashboardObserver:
        self._thread = threading.Thread(target=self._run, name="dashboard-observer", daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *_: object) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5)

    def get(self, robot: str, topic: str) -> dict[str, Any] | None:
        return self.latest.get((robot, topic))

    def _run(self) -> None:
        from websockets.sync.client import connect

        try:
            with connect(self.ws_url, max_size=None) as ws:
                for topic in self.topics:
                    ws.send(json.dumps({"op": "subscribe", "robot": "*", "topic": topic, "max_hz": self.max_hz}))
                while not self._stop.is_set():
                    try:
                        raw = ws.recv(timeout=0.5)
                    except TimeoutError:
                        continue
                    if isinstance(raw, str):
                        for frame in unbatch(json.loads(raw)):
                            if frame.get("type") == "msg":
                                self._seen(frame)
        except Exception as exc:  # surfaced by the test through .error
            self.error = repr(exc)

    def _seen(self, frame: dict[str, Any]) -> None:
        self.latest[(frame["robot"], frame["topic"])] = frame
        if frame["topic"] == "diagnostics" and frame["source"] == "live":
            for status in frame["data"]["status"]:
                for kv in status["values"]:
                    if kv["key"] == "real_time_factor":
                        self.real_time_factors.append((time.time(), float(kv["value"])))


def cpu_by_process(processes: list[psutil.Process], seconds: float) -> list[tuple[str, float]]:
    """CPU % of one core each process used over ``seconds``, busiest first (names shortened to what ran)."""
    for p in processes:
        with contextlib.suppress(psutil.Error):
            p.cpu_percent(None)
    time.sleep(seconds)
    out = []
    for p in processes:
        with contextlib.suppress(psutil.Error):
            out.append((_label(p), p.cpu_percent(None)))
    return sorted(out, key=lambda x: -x[1])


def _label(p: psutil.Process) -> str:
    return f"{process_label(p)} [{p.pid}]"


def process_label(p: psutil.Process) -> str:
    """What a process of the stack runs: its module (pitchside.cli with its command) and robot, or its program."""
    cmd = p.cmdline()
    if "-m" in cmd:
        i = cmd.index("-m")
        extra = [a for a in cmd[i + 2:] if not a.startswith("-")][:1] if cmd[i + 1] == "pitchside.cli" else []
        robot = cmd[cmd.index("--robot-id") + 1] if "--robot-id" in cmd else ""
        return " ".join(x for x in (cmd[i + 1], *extra, robot) if x)
    kind = next((a.split("=", 1)[1] for a in cmd if a.startswith("--type=")), "")
    return f"{Path(cmd[0]).name if cmd else p.name()} {kind}".strip()
