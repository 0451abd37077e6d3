"""Test and bench helper: the real Foxglove client (tests/foxglove_client/client.mjs, on Node.js) as a subprocess.

Its packages (@foxglove/ws-protocol, ws, @foxglove/rosmsg2-serialization) are pinned by the folder's
package-lock.json and installed by ``./run test`` (npm ci), never at test time.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from typing import Any

from tests.support import REPO

CLIENT_DIR = REPO / "tests" / "foxglove_client"
CLIENT = CLIENT_DIR / "client.mjs"
# what the server prints at start (server.foxglove.endpoint.FoxgloveEndpoint.banner)
BANNER = re.compile(r"pitchside foxglove: (wss?://\S+)")


class MissingClient(RuntimeError):
    """Node.js or the client's packages are missing (``./run test`` installs the packages with npm ci)."""


def foxglove_url(server_output: str) -> str | None:
    """The endpoint's URL from what the server printed, None before it printed it."""
    match = BANNER.search(server_output)
    return match.group(1) if match else None


def node_client(mode: str, url: str, *args: str) -> subprocess.Popen[str]:
    """The client running ``mode`` (probe, list, stall, latency); its one JSON line comes on stdout."""
    node = shutil.which("node")
    if node is None:
        raise MissingClient("node is not on PATH (Debian: apt-get install nodejs npm)")
    if not (CLIENT_DIR / "node_modules" / "@foxglove" / "ws-protocol").exists():
        raise MissingClient(f"the Foxglove client's packages are not installed: run ./run test, or npm ci in "
                            f"{CLIENT_DIR.relative_to(REPO)}")
    return subprocess.Popen([node, str(CLIENT), mode, url, *args], cwd=CLIENT_DIR, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def run_client(mode: str, url: str, *args: str, timeout: float = 60.0) -> dict[str, Any]:
    """Runs the client to its end and returns what it printed."""
    return client_result(node_client(mode, url, *args), mode, timeout)


def client_result(proc: subprocess.Popen[str], mode: str, timeout: float = 60.0) -> dict[str, Any]:
    """What a client started with ``node_client`` printed, once it ended."""
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        raise AssertionError(f"foxglove client {mode} did not finish in {timeout} s: {err[-2000:]}") from None
    lines = [line for line in out.splitlines() if line.startswith("{")]
    if proc.returncode != 0 or not lines:
        raise AssertionError(f"foxglove client {mode} failed ({proc.returncode}): {out[-2000:]} {err[-2000:]}")
    result: dict[str, Any] = json.loads(lines[-1])
    return result


def run_session(url: str, steps: list[dict[str, Any]], seconds: float = 20.0, timeout: float = 120.0
                ) -> dict[str, Any]:
    """The client's ``session`` mode: the steps one after another, each answered (at most ``seconds``); what came
    back, with every status, parameter value, graph update, service and playback state the server sent meanwhile."""
    return run_client("session", url, "--script", json.dumps(steps), "--seconds", str(seconds), timeout=timeout)
