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
    assert topics["rosout"]["msgtype"] == "rcl_interfaces/msg/Log" and topics["rosout"]["robot"] == "replay.log"
    assert 4.4 < info["duration_s"] < 4.6
    _post(server, "speed", {"speed": 10})
    frames = asyncio.run(_collect(server.ws_url, [{"robot": "*", "topic": "*"}],
                                  lambda fs: sum(f["topic"] == "topic" for f in fs) >= 10,
                                  action=lambda: _post(server, "play")))
    texts = [f["data"]["data"] for f in frames if f["topic"] == "topic"]
    assert texts == [f"Hello, world! {i}" for i in range(10)]
    rosout = next(f for f in frames if f["topic"] == "rosout")
    assert rosout["robot"] == "replay.log" and rosout["source"] == "replay" and rosout["data"]["level"] == 20
    assert "DEBUG" not in rosout["data"]  # constants are not fields
    wait_for(lambda: server.http.get(f"{server.url}/api/replay").json()["state"] == "ended", timeout=20,
             what="replay ended")

    info = _post(server, "open", {"path": str(testdata / "mcap" / "cdr_test_0.mcap")})
    assert {t["topic"] for t in info["topics"]} == {"test_topic", "array_topic"}
    frames = asyncio.run(_collect(server.ws_url, [{"robot": "replay.log", "topic": "test_topic"}],
                                  lambda fs: len(fs) >= 3, action=lambda: _post(server, "play")))
    values = [f["data"]["int32_value"] for f in frames]
    assert values[0] == 123 and all(isinstance(v, int) for v in values)  # a numeric field, ready to plot

    assert server.http.post(f"{server.url}/api/replay/open", json={"path": "nope.mcap"}).status_code == 404
    assert server.http.post(f"{server.url}/api/replay/speed", json={"speed": 50}).status_code == 422


def _pitchside_log(path: Path, seconds: float = 20.0, stale_s: float = 0.0) -> None:
    """Two robots' joint states at 50 Hz, a gamestate at 1 Hz and a bookmark at 10 s; with ``stale_s``, the log
    opens with a stale game state from that long before its data (what recordings before 0.x started with)."""
    with LogWriter(path, chunk_size=64 * 1024) as writer:
        if stale_s:
            writer.write("r1", "gamestate", schemas.make("humanoid_league_msgs/msg/GameState", game_state=4),
                         log_time_ns=T0 - int(stale_s * 1e9))
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
    assert info["robots"] == ["replay.r1", "replay.r2"]  # apart from live robots r1 and r2
    assert [(b["name"], round(b["t_s"], 3)) for b in info["bookmarks"]] == [("goal own 1:0", 10.0)]
    assert {(t["robot"], t["topic"]): t["count"] for t in info["topics"]}[("replay.r2", "joint_states")] == 1000
    listing = server.http.get(f"{server.url}/api/recordings").json()["files"]
    assert listing[0]["name"] == "game.mcap" and abs(listing[0]["duration_s"] - 19.98) < 0.01

    # seek: every panel gets each stream's state just before the point, from both robots
    frames = asyncio.run(_collect(server.ws_url, [{"robot": "*", "topic": "joint_states"}],
                                  lambda fs: {f["robot"] for f in fs} == {"replay.r1", "replay.r2"},
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
    assert {r["robot"] for r in robots} == {"replay.r1", "replay.r2"}
    assert robots[0]["streams"]["joint_states"]["source"] == "replay" and robots[0]["replayed"] is True
    assert robots[0]["log_robot"] == "r1"  # as the log's messages (ground truth's robot_ids) name it
    _post(server, "close")  # the replayed robots leave with their log
    assert server.http.get(f"{server.url}/api/robots").json() == []


def test_crash_cut_log_is_scanned_with_progress(tmp_path: Path) -> None:
    """A log without its summary (a crashed recorder) is read in one pass; progress goes to 1, and while it
    loads the status names the file (the playback bar shows which log it is)."""
    from server.hub import Hub
    from server.sources.replay import ReplaySource

    whole = tmp_path / "whole.mcap"
    _pitchside_log(whole, seconds=10.0)
    cut = tmp_path / "cut.mcap"
    data = whole.read_bytes()
    cut.write_bytes(data[: len(data) * 2 // 3])  # the summary and the last chunks are gone
    seen: list[float] = []
    loading: list[dict[str, Any]] = []

    async def main() -> dict[str, Any]:
        hub = Hub()
        hub.bind(asyncio.get_running_loop())
        source = ReplaySource(hub, tmp_path)
        original = source._on_progress
        source._on_progress = lambda f: (seen.append(f), loading.append(source.status()), original(f))  # type: ignore[method-assign]
        info = await source.open("cut.mcap")
        status = await source.seek(3.0)
        await source.close()
        return {"info": info, "status": status}

    result = asyncio.run(main())
    info = result["info"]
    assert seen and seen[-1] == 1.0 and seen == sorted(seen)
    assert {(st["state"], st["path"]) for st in loading} == {("loading", str(cut))}
    assert result["status"]["progress"] == 1.0 and abs(result["status"]["position_s"] - 3.0) < 1e-6
    assert 0 < info["messages"] < 2 * 500 + 20 and info["robots"] == ["replay.r1", "replay.r2"]
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


def test_replayed_robots_apart_from_live_ones(tmp_path: Path) -> None:
    """A live r1 and the log's r1 are two robots: live data stays live, the replayed one leaves on close."""
    from server.hub import Hub, HubMessage
    from server.sources.replay import ReplaySource

    _pitchside_log(tmp_path / "game.mcap", seconds=2.0)

    async def main() -> dict[str, Any]:
        hub = Hub()
        hub.bind(asyncio.get_running_loop())
        live = schemas.make("sensor_msgs/msg/JointState", name=["head_pan"], position=[-1.0])
        hub.publish(HubMessage("r1", "joint_states", "sensor_msgs/msg/JointState", time.time(), live, "live"))
        source = ReplaySource(hub, tmp_path)
        await source.open("game.mcap")
        await source.step(10)
        during = {robot: {t: m.source for (r, t), m in hub.latest.items() if r == robot} for robot in hub.robots}
        live_position = float(hub.latest[("r1", "joint_states")].message.position[0])
        await source.close()
        return {"during": during, "live_position": live_position, "after": sorted(hub.robots)}

    result = asyncio.run(main())
    assert result["during"]["r1"] == {"joint_states": "live"}
    assert result["during"]["replay.r1"]["joint_states"] == "replay" and "replay.r2" in result["during"]
    assert result["live_position"] == -1.0  # the replay did not overwrite the live robot
    assert result["after"] == ["r1"]


def test_timeline_starts_at_the_real_data(server: RunningServer, tmp_path: Path) -> None:
    """A log that opens with a game state from 9 minutes before its half: the timeline (and the listing) start at
    the half's data, and the stale message is not played."""
    folder = tmp_path / "rec"
    folder.mkdir(exist_ok=True)
    _pitchside_log(folder / "half.mcap", seconds=10.0, stale_s=540.0)
    info = _post(server, "open", {"path": "half.mcap"})
    assert abs(info["duration_s"] - 9.98) < 0.01 and info["start_ns"] == T0
    assert [round(b["t_s"], 3) for b in info["bookmarks"]] == []  # the 10 s bookmark is past this 9.98 s log
    listing = server.http.get(f"{server.url}/api/recordings").json()["files"]
    assert abs(next(f for f in listing if f["name"] == "half.mcap")["duration_s"] - 9.98) < 0.01
    frames = asyncio.run(_collect(server.ws_url, [{"robot": "*", "topic": "gamestate"}], lambda fs: len(fs) >= 1,
                                  action=lambda: _post(server, "step", {"count": 5})))
    assert frames[0]["data"]["game_state"] == 3  # the half's PLAYING, not the stale FINISHED


def test_new_recordings_do_not_open_with_stale_messages(tmp_path: Path) -> None:
    """Each stream's newest message opens a recording only if it is recent; an old one would stretch the timeline."""
    from schemas.logs import LogReader
    from server.hub import Hub, HubMessage
    from server.recording.session import OPENING_FRESH_S, HubRecording

    async def main() -> list[tuple[str, str]]:
        hub = Hub()
        hub.bind(asyncio.get_running_loop())
        game = schemas.make("humanoid_league_msgs/msg/GameState", game_state=4)
        joints = schemas.make("sensor_msgs/msg/JointState", name=["head_pan"], position=[0.5])
        old = HubMessage("r1", "gamestate", "humanoid_league_msgs/msg/GameState", time.time() - 540, game, "live",
                         received=time.monotonic() - 540)
        hub.publish(old)
        hub.publish(HubMessage("r1", "joint_states", "sensor_msgs/msg/JointState", time.time(), joints, "live"))
        assert time.monotonic() - hub.latest[("r1", "joint_states")].received < OPENING_FRESH_S
        recording = HubRecording(hub, tmp_path / "new.mcap", "manual")
        await recording.stop()
        with LogReader(tmp_path / "new.mcap") as reader:
            return [(m.robot_id, m.topic) for m in reader.messages(decode=False)]

    assert asyncio.run(main()) == [("r1", "joint_states")]


def test_notes_on_a_replayed_log(server: RunningServer, tmp_path: Path) -> None:
    """A bookmark at the replay's position goes into a sidecar beside the log, is listed with the log's own
    bookmarks, comes back when the log is opened again, and leaves the MCAP file as it was."""
    folder = tmp_path / "rec"
    folder.mkdir(exist_ok=True)
    _pitchside_log(folder / "game.mcap")
    original = (folder / "game.mcap").read_bytes()
    refused = server.http.post(f"{server.url}/api/replay/bookmark", json={"name": "x"})
    assert refused.status_code == 409  # no log open
    _post(server, "open", {"path": "game.mcap"})
    _post(server, "seek", {"t_s": 12.5})
    note = _post(server, "bookmark", {"name": "fell here"})
    assert note["kind"] == "note" and abs(note["t_s"] - 12.5) < 1e-6
    _post(server, "bookmark", {"name": "before", "t_s": 3.0})
    bad = server.http.post(f"{server.url}/api/replay/bookmark", json={"name": "  "})
    assert bad.status_code == 422 and "name" in bad.json()["detail"]
    _post(server, "close")
    info = _post(server, "open", {"path": "game.mcap"})  # another session
    assert [(b["name"], b["kind"], round(b["t_s"], 3)) for b in info["bookmarks"]] == [
        ("before", "note", 3.0), ("goal own 1:0", "log", 10.0), ("fell here", "note", 12.5)]
    assert info["notes_file"] == str(folder / "game.mcap.notes.json")
    assert (folder / "game.mcap").read_bytes() == original
    _post(server, "close")
