"""rerun's gRPC server and web viewer as a child process that listens on loopback only.

The SDK's own ``rr.serve_grpc`` listens on every interface (rerun 0.41's Python bindings fix 0.0.0.0) and answers
any Host and any localhost origin, so anyone on the venue network, and a DNS-rebinding page in the laptop's
browser, could read the plots. The ``rerun`` CLI shipped in the same wheel takes ``--bind``: it serves the viewer's
files and the data on 127.0.0.1, on ports browsers refuse by default (server.loopback_ports), and the
dashboard passes both through its own origin (server.routers.plots). The SDK logs into it over gRPC.

The child dies with the dashboard (PR_SET_PDEATHSIG), so a killed dashboard leaves no server holding the plots.
rerun's usage analytics are off in it (rerun skips them when ``CI`` is set; offline they would fail anyway).
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import ctypes
import logging
import os
import signal
import sys
from importlib.resources import files
from pathlib import Path

from server.loopback_ports import LOOPBACK, internal_port

log = logging.getLogger(__name__)
START_TIMEOUT_S = 20.0
STOP_TIMEOUT_S = 5.0
_PR_SET_PDEATHSIG = 1
_prctl = ctypes.CDLL(None, use_errno=True).prctl if sys.platform.startswith("linux") else None


class RerunServerError(RuntimeError):
    """rerun's server could not start (its CLI is missing, its ports are taken, or it exited)."""


def _die_with_parent() -> None:
    """Runs in the child between fork and exec: SIGTERM when the dashboard ends, however it ends."""
    if _prctl is not None:
        _prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)


def rerun_cli() -> Path:
    """The rerun binary in the rerun-sdk wheel (package ``rerun_cli``)."""
    folder = Path(str(files("rerun_cli")))
    app = folder / "Rerun.app" / "Contents" / "MacOS" / "Rerun"
    exe = app if sys.platform == "darwin" and app.exists() else folder / ("rerun.exe" if os.name == "nt" else "rerun")
    if not exe.exists():
        raise RerunServerError(f"the rerun CLI is missing from rerun-sdk (looked for {exe})")
    return exe


class RerunServer:
    """``rerun --serve-web --bind 127.0.0.1``: the gRPC proxy the SDK logs into and the viewer reads from, and the
    viewer's files. Ports 0 mean: each on a browser-blocked port (server.loopback_ports)."""

    def __init__(self, grpc_port: int = 0, web_port: int = 0, memory_limit: str = "256MiB") -> None:
        self.wanted = (grpc_port, web_port)
        self.grpc_port = grpc_port
        self.web_port = web_port
        self.memory_limit = memory_limit
        self.process: asyncio.subprocess.Process | None = None
        self.output: collections.deque[str] = collections.deque(maxlen=20)  # its last log lines, for errors
        self._reader: asyncio.Task[None] | None = None

    @property
    def url(self) -> str:
        """Where the SDK sends and the dashboard's relay reads (rerun's own URL form)."""
        return f"rerun+http://{LOOPBACK}:{self.grpc_port}/proxy"

    @property
    def running(self) -> bool:
        return self.process is not None and self.process.returncode is None

    async def start(self) -> None:
        """Starts the child and waits until both ports answer; a port taken meanwhile is retried with another
        (only when the port was not given)."""
        exe = rerun_cli()
        for attempt in range(3):
            self.grpc_port = internal_port(self.wanted[0], "plots (rerun's gRPC server)")
            # the viewer's files too: rerun's file server answers any Host, so a page that rebinds its name to
            # loopback could otherwise load the viewer from it (and, given a gRPC port it may open, the plots)
            self.web_port = internal_port(self.wanted[1], "plots (rerun's viewer files)", avoid=(self.grpc_port,))
            try:
                await self._spawn(exe)
                return
            except RerunServerError:
                await self.stop()
                if all(self.wanted) or attempt == 2:
                    raise
                log.info("rerun's server did not start on ports %d/%d, trying others", self.grpc_port,
                         self.web_port)

    async def _spawn(self, exe: Path) -> None:
        env = dict(os.environ, CI="1", TELEMETRY_ENABLED="false", RUST_LOG=os.environ.get("RUST_LOG", "warn"))
        self.output.clear()
        self.process = await asyncio.create_subprocess_exec(
            str(exe), "--serve-web", "--bind", LOOPBACK, "--port", str(self.grpc_port),
            "--web-viewer-port", str(self.web_port), "--server-memory-limit", self.memory_limit,
            stdin=asyncio.subprocess.DEVNULL, stdout=asyncio.subprocess.DEVNULL, stderr=asyncio.subprocess.PIPE,
            env=env, preexec_fn=_die_with_parent if _prctl is not None else None)
        self._reader = asyncio.create_task(self._read_output(self.process))
        deadline = asyncio.get_running_loop().time() + START_TIMEOUT_S
        for port in (self.grpc_port, self.web_port):
            while not await _answers(port):
                if self.process.returncode is not None:
                    await asyncio.sleep(0.1)  # its last words
                    raise RerunServerError(f"rerun's server exited with {self.process.returncode}: "
                                           + " | ".join(self.output))
                if asyncio.get_running_loop().time() > deadline:
                    raise RerunServerError(f"rerun's server did not listen on {LOOPBACK}:{port} within "
                                           f"{START_TIMEOUT_S:.0f} s: " + " | ".join(self.output))
                await asyncio.sleep(0.05)

    async def _read_output(self, process: asyncio.subprocess.Process) -> None:
        assert process.stderr is not None
        async for raw in process.stderr:
            line = raw.decode(errors="replace").rstrip()
            if line:
                self.output.append(line)
                log.debug("rerun: %s", line)
        if process.returncode not in (None, 0, -signal.SIGTERM):
            log.warning("rerun's server ended with %s: %s", process.returncode, " | ".join(self.output))

    async def stop(self) -> None:
        process, self.process = self.process, None
        if process is not None and process.returncode is None:
            process.terminate()
            try:
                await asyncio.wait_for(process.wait(), STOP_TIMEOUT_S)
            except TimeoutError:
                process.kill()
                await process.wait()
        if self._reader is not None:
            with contextlib.suppress(BaseException):
                await asyncio.wait_for(self._reader, STOP_TIMEOUT_S)
            self._reader = None


async def _answers(port: int) -> bool:
    try:
        _, writer = await asyncio.open_connection(LOOPBACK, port)
    except OSError:
        return False
    writer.close()
    with contextlib.suppress(OSError):
        await writer.wait_closed()
    return True
