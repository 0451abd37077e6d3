"""Telemetry into the dashboard: a robot's real TelemetryNode sends one-way UDP to a server in match mode."""

from __future__ import annotations

import json
import socket
import time
from pathlib import Path
from typing import Any

import httpx
import pytest

from robot_nodes.runtime import BusConfig
from server.protocol import unbatch
from tests.dashboard_server import dashboard_server
from tests.support import free_port
from tests.teststand import SceneStand
from tests.waiting import wait_for


def test_match_mode_server_shows_telemetry(bus: BusConfig, tmp_path: Path) -> None:
    sender = pytest.importorskip("robot_nodes.telemetry.sender")
    ws_client = pytest.importorskip("websockets.sync.client")
    port = free_port(socket.SOCK_DGRAM)
    args = ["--match", "--allow-dev-key", "--telemetry-host", "127.0.0.1", "--telemetry-port", str(port)]
    with dashboard_server(args, tmp_path) as server:
        stand = SceneStand("r3", bus).start()
        telemetry = sender.TelemetryNode("r3", bus, overrides={"destination": f"127.0.0.1:{port}",
                                                                          "allow_dev_key": True}).start()
        try:
            with ws_client.connect(server.ws_url) as ws:
                ws.send(json.dumps({"op": "subscribe", "robot": "r3", "topic": "robot_state"}))
                ws.send(json.dumps({"op": "subscribe", "robot": "r3", "topic": "overview"}))
                got: dict[str, Any] = {}
                deadline = time.monotonic() + 30
                # the first overviews may precede the sender's first robot_state (hcm_state 255 = unknown)
                # and its first position (pose_known false)
                def complete() -> bool:
                    overview = got.get("overview", {}).get("data", {})
                    return "robot_state" in got and overview.get("hcm_state") == 10 and overview.get("pose_known")

                while time.monotonic() < deadline and not complete():
                    for frame in unbatch(json.loads(ws.recv(timeout=30))):
                        if frame["type"] == "msg":
                            got[frame["topic"]] = frame
            assert got["robot_state"]["data"] == {"state": 10} and got["robot_state"]["source"] == "telemetry"
            assert got["overview"]["data"]["hcm_state"] == 10 and got["overview"]["data"]["pose_x"] == -2.0

            def health() -> Any:
                robots = httpx.get(f"{server.url}/api/robots", timeout=10).json()
                streams = robots[0]["streams"] if robots else {}
                return streams if "loss_pct" in streams.get("robot_state", {}) else None

            streams = wait_for(health, 20.0, 0.2, "link health of the telemetry streams")
            assert streams["robot_state"]["loss_pct"] == 0.0
            assert 0.0 < streams["robot_state"]["budget_share"] < 1.0
        finally:
            telemetry.shutdown()
            stand.shutdown()
