"""Replay through a real server: ROS 2 bags from others and pitchside logs feed the hub, the timeline works."""

from __future__ import annotations

import asyncio
import json
import time
from pathlib import Path
from typing import Any

import pytest
import websockets

import schemas
from schemas.logs import LogWriter
from server.protocol import unbatch
from tests.dashboard_server import RunningServer, dashboard_server
from tests.support import TESTDATA
from tests.waiting import wait_for

T0 = 1_700_000_000_000_000_000  # ns


@pytest.fixture
def server(tmp_path: Path) -> Any:
    args = ["--no-live", "--no-telemetry", "--recordings", str(tmp_path / "rec"), "--allow-folder", str(TESTDATA)]
    with dashboard_server(args, tmp_path) as s:
        yield s


def _post(server: RunningServer, path: str, body: dict[str, Any] | None = None) -> dict[str, Any]:
    response = server.http.post(f"{server.url}/api/replay/{path}", json=body or {}, timeout=30)
    assert response.status_code == 200, response.text
    return response.json()  # type: ignore[no-any-return]


async def _collect(url: str, subscriptions: list[dict[str, Any]], until: Any, action: Any = None,
                   timeout: float = 30.0) -> list[dict[str, Any]]:
    """Msg frames (subscribed as given) until ``until(frames)`` holds; ``action()`` runs once subscribed."""
    frames: list[dict[str, Any]] = []
    async with websockets.connect(url, max_size=None) as ws:
        for sub in subscriptions:
            await ws.send(json.dumps({"op": "subscribe", **sub}))
        await ws.send(json.dumps({"op": "ping", "id": 1}))
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:  # the pong: subscriptions are in place
            raw = await asyncio.wait_for(ws.recv(), deadline - time.monotonic())
            if isinstance(raw, str) and any(f["type"] == "pong" for f in unbatch(json.loads(raw))):
                break
        if action is not None:
            await asyncio.to_thread(action)
        while not until(frames):
            left = deadline - time.monotonic()
            if left <= 0:
                raise AssertionError(f"timed out; got {len(frames)} frames: {frames[-3:]}")
            raw = await asyncio.wait_for(ws.recv(), left)
            if isinstance(raw, str):
                frames += [f for f in unbatch(json.loads(raw)) if f["type"] == "msg"]
    return frames


def test_ros2_bags_from_others(server: RunningServer, testdata: Path) -> None:
    info = _post(server, "open", {"path": str(testdata / "mcap" / "talker.mcap")})
    topics = {t["topic"]: t for t in info["topics"]}
    assert topics["topic"]["msgtype"] == "std_msgs/msg/String" and topics["topic"]["count"] == 10
    assert topics["rosout"]["msgtype"] == "rcl_interfaces/msg/Log" and topics["rosout"]["robot"] == "replay"
    assert 4.4 < info["duration_s"] < 4.6
    _post(server, "speed", {"speed": 10})
    frames = asyncio.run(_collect(server.ws_url, [{"robot": "*", "topic": "*"}],
                                  lambda fs: sum(f["topic"] == "topic" for f in fs) >= 10,
                                  action=lambda: _post(server, "play")))
    texts = [f["data"]["data"] for f in frames if f["topic"] == "topic"]
    assert texts == [f"Hello, world! {i}" for i in range(10)]
    rosout = next(f for f in frames if f["topic"] == "rosout")
    assert rosout["robot"] == "replay" and rosout["source"] == "replay" and rosout["data"]["level"] == 20
    assert "DEBUG" not in rosout["data"]  # constants are not fields
    wait_for(lambda: server.http.get(f"{server.url}/api/replay").json()["state"] == "ended", timeout=20,
             what="replay ended")

    info = _post(server, "open", {"path": str(testdata / "mcap" / "cdr_test_0.mcap")})
    assert {t["topic"] for t in info["topics"]} == {"test_topic", "array_topic"}
    frames = asyncio.run(_collect(server.ws_url, [{"robot": "replay", "topic": "test_topic"}],
                                  lambda fs: len(fs) >= 3, action=lambda: _post(server, "play")))
    values = [f["data"]["int32_value"] for f in frames]
    assert values[0] == 123 and all(isinstance(v, int) for v in values)  # a numeric field, ready to plot

    assert server.http.post(f"{server.url}/api/replay/open", json={"path": "nope.mcap"}).status_code == 404
    assert server.http.post(f"{server.url}/api/replay/speed", json={"speed": 50}).status_code == 422


def _pitchside_log(path: Path, seconds: float = 20.0) -> None:
    """Two robots' joint states at 50 Hz, a gamestate at 1 Hz and a bookmark at 10 s."""
    with LogWriter(path, chunk_size=64 * 1024) as writer:
        for k in range(int(seconds * 50)):
            t = T0 + k * 20_000_000
            for robot in ("r1", "r2"):
                msg = schemas.make("sensor_msgs/msg/JointState", name=["head_pan"], position=[k * 0.02])
                writer.write(robot, "joint_states", msg, log_time_ns=t)
            if k % 50 == 0:
                writer.write("r1", "gamestate", schemas.make("humanoid_league_msgs/msg/GameState", game_state=3,
                                                               own_score=k // 500), log_time_ns=t)
            if k == 500:
                writer.add_bookmark("goal own 1:0", log_time_ns=t, data={"own_score": 1})


def test_pitchside_log_seek_speed_step(server: RunningServer, tmp_path: Path) -> None:
    folder = tmp_path / "rec"
    folder.mkdir(exist_ok=True)
    _pitchside_log(folder / "game.mcap")
    info = _post(server, "open", {"path": "game.mcap"})  # a bare name: from the recordings folder
    assert info["robots"] == ["r1", "r2"]
    assert [(b["name"], round(b["t_s"], 3)) for b in info["bookmarks"]] == [("goal own 1:0", 10.0)]
    assert {(t["robot"], t["topic"]): t["count"] for t in info["topics"]}[("r2", "joint_states")] == 1000
    listing = server.http.get(f"{server.url}/api/recordings").json()["files"]
    assert listing[0]["name"] == "game.mcap" and abs(listing[0]["duration_s"] - 19.98) < 0.01

    # seek: every panel gets each stream's state just before the point, from both robots
    frames = asyncio.run(_collect(server.ws_url, [{"robot": "*", "topic": "joint_states"}],
                                  lambda fs: {f["robot"] for f in fs} == {"r1", "r2"},
                                  action=lambda: _post(server, "seek", {"t_s": 12.0})))
    assert all(abs(f["data"]["position"][0] - 11.98 * 50 * 0.02) < 0.05 for f in frames)
    status = server.http.get(f"{server.url}/api/replay").json()
    assert status["state"] == "paused" and abs(status["position_s"] - 12.0) < 1e-6

    # step: the next messages, in log order
    stepped = _post(server, "step", {"count": 2})
    assert abs(stepped["position_s"] - 12.0) < 1e-6 and stepped["delivered"] == 2

    # 10x: the remaining 8 s of log play in well under 8 s of wall time, and the timeline follows
    _post(server, "speed", {"speed": 10.0})
    started = time.monotonic()
    _post(server, "play")
    wait_for(lambda: server.http.get(f"{server.url}/api/replay").json()["state"] == "ended", timeout=30,
             interval=0.05, what="replay ended")
    assert time.monotonic() - started < 6.0
    status = server.http.get(f"{server.url}/api/replay").json()
    assert abs(status["position_s"] - 19.98) < 1e-6 and status["delivered"] >= 2 * 8 * 50
    robots = server.http.get(f"{server.url}/api/robots").json()
    assert {r["robot"] for r in robots} >= {"r1", "r2"}
    assert robots[0]["streams"]["joint_states"]["source"] == "replay"


def test_crash_cut_log_is_scanned_with_progress(tmp_path: Path) -> None:
    """A log without its summary (a crashed recorder) is read in one pass; progress goes to 1."""
    from server.hub import Hub
    from server.sources.replay import ReplaySource

    whole = tmp_path / "whole.mcap"
    _pitchside_log(whole, seconds=10.0)
    cut = tmp_path / "cut.mcap"
    data = whole.read_bytes()
    cut.write_bytes(data[: len(data) * 2 // 3])  # the summary and the last chunks are gone
    seen: list[float] = []

    async def main() -> dict[str, Any]:
        hub = Hub()
        hub.bind(asyncio.get_running_loop())
        source = ReplaySource(hub, tmp_path)
        original = source._on_progress
        source._on_progress = lambda f: (seen.append(f), original(f))  # type: ignore[method-assign]
        info = await source.open("cut.mcap")
        status = await source.seek(3.0)
        await source.close()
        return {"info": info, "status": status}

    result = asyncio.run(main())
    info = result["info"]
    assert seen and seen[-1] == 1.0 and seen == sorted(seen)
    assert result["status"]["progress"] == 1.0 and abs(result["status"]["position_s"] - 3.0) < 1e-6
    assert 0 < info["messages"] < 2 * 500 + 20 and info["robots"] == ["r1", "r2"]
    assert any("not closed cleanly" in w for w in info["warnings"])


def test_replay_and_recording_allowed_in_match_mode(testdata: Path, tmp_path: Path) -> None:
    args = ["--match", "--allow-dev-key", "--no-telemetry", "--recordings", str(tmp_path / "rec"), "--replay",
            str(testdata / "mcap" / "talker.mcap")]
    with dashboard_server(args, tmp_path) as server:
        wait_for(lambda: server.http.get(f"{server.url}/api/replay").json()["state"] == "paused", timeout=20,
                 what="log opened")
        assert _post(server, "play")["state"] == "playing"
        assert server.http.post(f"{server.url}/api/recordings/start", json={}).status_code == 200
        assert server.http.post(f"{server.url}/api/recordings/stop").status_code == 200
        assert server.http.post(f"{server.url}/api/robots/r1/penalize", json={"penalize": True}).status_code == 403


def test_seek_while_playing_keeps_playing(server: RunningServer, tmp_path: Path) -> None:
    """Seeking on the timeline during playback goes on playing from the new point (it used to freeze there)."""
    folder = tmp_path / "rec"
    folder.mkdir(exist_ok=True)
    _pitchside_log(folder / "game.mcap")
    _post(server, "open", {"path": "game.mcap"})
    assert _post(server, "play")["state"] == "playing"
    sought = _post(server, "seek", {"t_s": 5.0})
    assert sought["state"] == "playing" and abs(sought["position_s"] - 5.0) < 1e-6
    wait_for(lambda: server.http.get(f"{server.url}/api/replay").json()["position_s"] > 5.5, timeout=20,
             what="position advances after a seek while playing")
    status = server.http.get(f"{server.url}/api/replay").json()
    assert status["state"] == "playing"
