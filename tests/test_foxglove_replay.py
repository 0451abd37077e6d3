"""Replay through the Foxglove endpoint (issue 17 point 7): while the server replays a log, the Foxglove client gets
its streams with the log's own timestamps, the log's time range, and plays, pauses, seeks and changes speed through
PlaybackControl, in step with the dashboard's replay panel both ways. The real server, a real log, the real client."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from schemas.logs import LogSeriesReader, data_start_ns
from tests.dashboard_server import RunningServer, dashboard_server
from tests.foxglove_node import foxglove_url, node_client, run_session
from tests.support import free_port
from tests.test_replay import T0, _pitchside_log
from tests.waiting import wait_for

pytestmark = pytest.mark.realtime

STEP_NS = 20_000_000  # the log's joint_states come every 20 ms from T0


def replay_status(server: RunningServer) -> dict[str, Any]:
    status: dict[str, Any] = server.http.get(f"{server.url}/api/replay").json()
    return status


def test_foxglove_plays_pauses_seeks_and_sets_the_speed_of_the_replay_in_step_with_the_panel(tmp_path: Path) -> None:
    log = tmp_path / "half.mcap"
    _pitchside_log(log)
    with LogSeriesReader(log) as reader:
        start, end = data_start_ns(reader), reader.end_ns
    with dashboard_server(["--replay", str(log), "--no-live", "--no-telemetry", "--no-auto-record",
                           "--foxglove-port", str(free_port())], tmp_path) as server:
        url = wait_for(lambda: foxglove_url(server.output()), timeout=30, what="the foxglove banner")
        assert url is not None
        wait_for(lambda: replay_status(server).get("state") == "paused", timeout=30, what="the log open")
        seek_to = start + 12 * 10**9
        session = node_client("session", f"{url}/?token={server.token}", "--script", json.dumps([
            {"op": "playback", "command": "play", "speed": 1.0},
            {"op": "waitChannel", "topic": "/replay.r1/joint_states"},
            {"op": "subscribe", "topic": "/replay.r1/joint_states", "count": 10},
            {"op": "playback", "command": "pause", "speed": 1.0},
            {"op": "waitPlayback", "status": "playing"},  # the panel's play button, pushed to Foxglove
            {"op": "waitPlayback", "status": "playing", "didSeek": True},  # the panel's seek
            {"op": "playback", "command": "pause", "speed": 2.0, "seek": seek_to}]), "--seconds", "30")
        assert session.stdout is not None
        progress = [json.loads(session.stdout.readline()) for _ in range(4)]
        assert progress[-1] == {"progress": "playback"}  # Foxglove paused the replay: the panel shows it
        assert replay_status(server)["state"] == "paused"
        # an app of the older subprotocol (Lichtblick before 2026) watching meanwhile, with the token: the SDK pushes
        # PlaybackState to the clients of its control server, which foxglove.websocket.v1 does not define
        older = node_client("session", f"{url}/?token={server.token}", "--subprotocol", "foxglove.websocket.v1",
                            "--script", json.dumps([{"op": "waitChannel", "topic": "/replay.r1/joint_states"},
                                                    {"op": "subscribe", "topic": "/replay.r1/joint_states",
                                                     "count": 5},  # once the panel plays
                                                    {"op": "wait", "ms": 6000}]), "--seconds", "30")
        assert older.stdout is not None
        assert json.loads(older.stdout.readline()) == {"progress": "waitChannel"}
        assert server.http.post(f"{server.url}/api/replay/play").status_code == 200
        assert json.loads(session.stdout.readline()) == {"progress": "waitPlayback"}
        assert server.http.post(f"{server.url}/api/replay/seek", json={"t_s": 3.0}).status_code == 200
        out, err = session.communicate(timeout=90)
        got = json.loads(out.splitlines()[-1])
        panel = replay_status(server)
        assert older.poll() is None  # still connected while the pushes the other client waited for went out
        older_out, older_err = older.communicate(timeout=60)
        old = json.loads(older_out.splitlines()[-1])
    assert old["subprotocol"] == "foxglove.websocket.v1" and old["errors"] == [], (old["errors"], older_err[-2000:])
    assert old["playback"] == [] and "playbackControl" in old["serverInfo"]["capabilities"]  # pushed, not passed
    [watched] = [r for r in old["results"] if r["op"] == "subscribe"]
    assert len(watched["messages"]) == 5
    assert got["errors"] == [], (got["errors"], err[-2000:])
    info = got["serverInfo"]
    assert {"playbackControl", "time"} <= set(info["capabilities"])
    assert info["dataStartTime"] == {"sec": start // 10**9, "nsec": start % 10**9}
    assert info["dataEndTime"] == {"sec": end // 10**9, "nsec": end % 10**9}
    played, paused, seeked = [r["state"] for r in got["results"] if r["op"] == "playback"]
    assert played["status"] == "playing" and played["speed"] == 1.0
    assert paused["status"] == "paused"
    # the log's own timestamps, not the wall clock's
    [subscribed] = [r for r in got["results"] if r["op"] == "subscribe"]
    stamps = [m["timestamp"] for m in subscribed["messages"]]
    assert len(stamps) == 10 and all(start <= t <= end and (t - T0) % STEP_NS == 0 for t in stamps), \
        (stamps, got["statuses"])
    # the panel's play and seek reached Foxglove by themselves
    pushed_play, pushed_seek = [r["state"] for r in got["results"] if r["op"] == "waitPlayback"]
    assert pushed_play["status"] == "playing" and not pushed_play["didSeek"]
    assert pushed_seek["didSeek"] and abs(pushed_seek["currentTime"] - (start + 3 * 10**9)) < 10**9
    # Foxglove's last request: seek to 12 s, speed 2x, paused; the panel shows the same
    assert seeked["status"] == "paused" and seeked["didSeek"] and seeked["speed"] == 2.0
    assert seeked["currentTime"] == seek_to
    assert panel["state"] == "paused" and panel["speed"] == 2.0 and abs(panel["position_s"] - 12.0) < 1e-6
    assert got["time"] is not None and start <= got["time"] <= end  # Foxglove's clock is the log's
    # the replayed robots in 3D, with their replay ids
    assert {"/replay.r1/tf", "/replay.r1/robot_description"} <= set(got["channels"])
    assert not any(c.startswith("/r1/") for c in got["channels"])


def test_without_the_token_a_client_watches_the_replay_but_cannot_control_it(tmp_path: Path) -> None:
    log = tmp_path / "half.mcap"
    _pitchside_log(log, seconds=4.0)
    with dashboard_server(["--replay", str(log), "--no-live", "--no-telemetry", "--no-auto-record",
                           "--foxglove-port", str(free_port())], tmp_path) as server:
        url = wait_for(lambda: foxglove_url(server.output()), timeout=30, what="the foxglove banner")
        assert url is not None
        wait_for(lambda: replay_status(server).get("state") == "paused", timeout=30, what="the log open")
        assert server.http.post(f"{server.url}/api/replay/play").status_code == 200
        got = run_session(url, [{"op": "waitChannel", "topic": "/replay.r2/joint_states"},
                                {"op": "subscribe", "topic": "/replay.r2/joint_states", "count": 3}])
        assert got["errors"] == [] and "playbackControl" not in got["serverInfo"]["capabilities"]
        assert "time" in got["serverInfo"]["capabilities"]
        [subscribed] = [r for r in got["results"] if r["op"] == "subscribe"]
        assert all(T0 <= m["timestamp"] <= T0 + 4 * 10**9 for m in subscribed["messages"])
        # the log closed: the endpoint serves live robots again (and no time range)
        assert server.http.post(f"{server.url}/api/replay/close").status_code == 200
        wait_for(lambda: "time" not in run_session(url, [], seconds=3)["serverInfo"]["capabilities"], timeout=30,
                 interval=0.5, what="the endpoint back to live")
