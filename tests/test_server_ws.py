"""The dashboard WebSocket end to end: a real node over a real Zenoh router, the server as a process, real clients."""

from __future__ import annotations

import asyncio
import base64
import json
import os
import socket
import struct
import time
from pathlib import Path
from typing import Any

import httpx
import psutil
import pytest
import websockets

from robot_nodes.runtime import BusConfig
from server.protocol import split_binary_frame, unbatch
from tests.dashboard_server import RunningServer, dashboard_server
from tests.teststand import TestStand
from tests.waiting import wait_for


@pytest.fixture
def server(router_endpoint: str, tmp_path: Path) -> Any:
    with dashboard_server(["--connect", router_endpoint, "--no-telemetry"], tmp_path) as running:
        yield running


@pytest.fixture
def stand(bus: BusConfig) -> Any:
    node = TestStand("r1", bus, overrides={"rate_hz": 50.0}).start()
    yield node
    node.shutdown()


async def _frames(ws: Any, seconds: float, kind: str = "msg") -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    deadline = time.monotonic() + seconds
    while (left := deadline - time.monotonic()) > 0:
        try:
            raw = await asyncio.wait_for(ws.recv(), left)
        except TimeoutError:
            break
        frames = unbatch(json.loads(raw)) if isinstance(raw, str) else [split_binary_frame(raw)[0]]
        out += [f for f in frames if f["type"] == kind]
    return out


async def _first(ws: Any, predicate: Any, timeout: float = 20.0) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        raw = await asyncio.wait_for(ws.recv(), deadline - time.monotonic())
        if isinstance(raw, str):
            for frame in unbatch(json.loads(raw)):
                if predicate(frame):
                    return frame
    raise AssertionError("frame not received")


def test_subscriber_receives_decoded_messages_and_robots(server: RunningServer, stand: TestStand) -> None:
    async def main() -> None:
        async with websockets.connect(server.ws_url) as ws:
            hello = json.loads(await ws.recv())
            assert hello == {"type": "hello", "match_mode": False, "server_time": hello["server_time"]}
            await ws.send(json.dumps({"op": "subscribe", "robot": "r1", "topic": "joint_states"}))
            joints = await _first(ws, lambda f: f["type"] == "msg")
            assert joints["robot"] == "r1" and joints["topic"] == "joint_states"
            assert joints["msgtype"] == "sensor_msgs/msg/JointState" and joints["source"] == "live"
            assert len(joints["data"]["name"]) == 20 and joints["data"]["name"][0] == "joint0"
            assert abs(joints["stamp"] - time.time()) < 30
            robots = await _first(ws, lambda f: f["type"] == "robots" and f["robots"])
            (r1,) = robots["robots"]
            assert r1["robot"] == "r1" and r1["status"] == "ok"
            assert r1["streams"]["robot_state"]["msgtype"] == "humanoid_league_msgs/msg/RobotControlState"
            await ws.send(json.dumps({"op": "subscribe", "robot": "*", "topic": "robot_state"}))
            state = await _first(ws, lambda f: f["type"] == "msg" and f["topic"] == "robot_state")
            assert state["data"] == {"state": 10}
            await ws.send(json.dumps({"op": "subscribe", "robot": "*", "topic": "x", "max_hz": "fast"}))
            error = await _first(ws, lambda f: f["type"] == "error")
            assert "max_hz" in error["error"]
            await ws.send(b"\x00\x01")
            error = await _first(ws, lambda f: f["type"] == "error")
            assert "text frames" in error["error"]
            await ws.send(json.dumps({"op": "ping", "id": 7}))
            pong = await _first(ws, lambda f: f["type"] == "pong")
            assert pong["id"] == 7

    asyncio.run(main())
    listed = httpx.get(f"{server.url}/api/robots").json()
    assert [r["robot"] for r in listed] == ["r1"]
    # the rate is measured over a window: right after the stand started it holds only the first messages
    wait_for(lambda: httpx.get(f"{server.url}/api/robots").json()[0]["streams"]["joint_states"]["rate_hz"] > 10,
             timeout=15, interval=0.2, what="joint_states at the stand's rate")


def test_rate_limit_per_subscription(server: RunningServer, stand: TestStand) -> None:
    async def main() -> None:
        async with websockets.connect(server.ws_url) as ws:
            await ws.send(json.dumps({"op": "subscribe", "robot": "r1", "topic": "joint_states", "max_hz": 4}))
            await _first(ws, lambda f: f["type"] == "msg")
            frames = await _frames(ws, 3.0)
        seqs = [f["data"]["position"][0] for f in frames]
        assert 4 <= len(frames) <= 3 * 4 + 2, len(frames)  # the node publishes 50 Hz
        assert seqs == sorted(seqs) and seqs[-1] - seqs[0] > 50  # thinned, not delayed: newest messages

    asyncio.run(main())


def _stuck_client(port: int, request: dict[str, Any]) -> socket.socket:
    """A WebSocket client that subscribes and then never reads a byte (tiny receive buffer)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall((f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                  f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n").encode())
    response = b""
    while b"\r\n\r\n" not in response:
        response += sock.recv(1)
    assert b" 101 " in response.split(b"\r\n")[0]
    payload = json.dumps(request).encode()
    mask = os.urandom(4)
    masked = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
    sock.sendall(struct.pack("!BB", 0x81, 0x80 | len(payload)) + mask + masked)
    return sock


def test_fifty_clients_one_never_reading(router_endpoint: str, bus: BusConfig, tmp_path: Path) -> None:
    node = TestStand("r1", bus, overrides={"rate_hz": 50.0, "image_hz": 20.0, "noisy_image": True}).start()
    try:
        with dashboard_server(["--connect", router_endpoint, "--no-telemetry"], tmp_path) as server:
            asyncio.run(_fifty_clients(server, node))
    finally:
        node.shutdown()


async def _fifty_clients(server: RunningServer, node: TestStand) -> None:
    proc = psutil.Process(server.process.pid)
    stuck = _stuck_client(server.port, {"op": "subscribe", "robot": "*", "topic": "*"})
    seen: list[set[int]] = [set() for _ in range(49)]
    measuring = asyncio.Event()

    async def reader(i: int) -> None:
        async with websockets.connect(server.ws_url) as ws:
            await ws.send(json.dumps({"op": "subscribe", "robot": "r1", "topic": "joint_states"}))
            while True:
                for frame in unbatch(json.loads(await ws.recv())):
                    if frame["type"] == "msg" and measuring.is_set():
                        seen[i].add(int(frame["data"]["position"][0]))

    def hub() -> dict[str, Any]:
        return httpx.get(f"{server.url}/api/hub", timeout=10).json()

    def browsers() -> list[dict[str, Any]]:  # the server has subscribers of its own too (the recorder)
        return [s for s in hub()["subscribers"] if s["name"].startswith("ws")]

    def stuck_sub() -> dict[str, Any]:
        return next(s for s in browsers() if s["subscriptions"] and s["subscriptions"][0]["topic"] == "*")

    tasks = [asyncio.create_task(reader(i)) for i in range(49)]
    try:
        await asyncio.to_thread(wait_for, lambda: len(browsers()) == 50, 60.0, 0.2, "50 subscribers")
        # the stuck client's socket is full once its own queue starts dropping frames
        await asyncio.to_thread(wait_for, lambda: stuck_sub()["dropped"] > 0, 60.0, 0.2, "stuck client dropping")
        rss_before = proc.memory_info().rss
        dropped_before = stuck_sub()["dropped"]
        measuring.set()
        first = node.seq + 5
        await asyncio.sleep(4.0)
        last = node.seq - 25  # allow for frames still in flight
        await asyncio.sleep(1.5)
        expected = set(range(first, last + 1))
        assert len(expected) > 100
        for i, got in enumerate(seen):
            missing = expected - got
            assert len(missing) <= 0.05 * len(expected), f"reader {i} missed {len(missing)} of {len(expected)}"
        stuck_now = stuck_sub()
        assert stuck_now["queued"] <= 2000 + 4
        assert stuck_now["dropped"] > dropped_before  # the stuck browser was still being served (and shed)
        growth = proc.memory_info().rss - rss_before
        assert growth < 80_000_000, f"server memory grew by {growth / 1e6:.0f} MB"
    finally:
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        stuck.close()
