"""The telemetry overview is a message like every other: RobotOverview from the datagram on, CDR in the hub and in
MCAP, JSON to the browser; recordings of earlier versions (JSON in a std_msgs/String) still replay."""

from __future__ import annotations

import asyncio
import json
import math
import time
from pathlib import Path
from typing import Any

import schemas
from schemas.logs import LogReader, LogWriter
from server.hub import Hub, HubMessage
from server.protocol import frame_of
from server.recording.session import HubRecording
from tests.dashboard_server import dashboard_server
from tests.test_replay import _collect, _post
from tests.waiting import wait_for
from wire.telemetry.datagram import (
    OVERVIEW_HASH,
    OVERVIEW_STREAM,
    DatagramWriter,
    Kind,
    encode_overview,
    new_overview,
)
from wire.telemetry.receiver import TelemetryReceiver

OVERVIEW_TYPE = "pitchside_msgs/msg/RobotOverview"
KEY = bytes(range(32))
T0 = 1_700_000_000_000_000_000  # ns
# what an earlier version's recorder wrote on topic "overview": the RobotOverview dataclass as JSON, NaN as null
LEGACY = {"hcm_state": 13, "game_state": 3, "secondary_state": 255, "penalized": False, "pose_known": True,
          "ball_known": False, "gamestate_known": True, "pose_x": 1.5, "pose_y": -0.25, "pose_theta": 0.5,
          "pose_confidence": 0.75, "ball_x": 0.0, "ball_y": 0.0, "ball_confidence": 0.0, "battery_voltage": None,
          "hottest_servo_temperature": 58.0, "hottest_servo": "LKnee", "own_score": 1, "rival_score": 2,
          "seconds_remaining": 300, "pose_age_ms": 40, "ball_age_ms": 65535}


def _received_overview() -> Any:
    """An overview as the team PC's receiver hands it on, from a real datagram."""
    sent = new_overview(hcm_state=10, pose_known=True, pose_x=-2.0, hottest_servo="RKnee",
                        hottest_servo_temperature=61.5)
    (datagram,) = DatagramWriter(KEY, "r2").message(Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH,
                                                    encode_overview(sent))
    (received,) = TelemetryReceiver(KEY).feed(datagram)
    assert received.type == OVERVIEW_TYPE and received.msg.__msgtype__ == OVERVIEW_TYPE
    # CDR like every other message (compared as JSON views: NaN is not equal to itself)
    assert schemas.to_dict(schemas.decode(received.payload, OVERVIEW_TYPE)) == schemas.to_dict(received.msg)
    return received.msg


def test_the_overview_is_recorded_as_its_message(tmp_path: Path) -> None:
    overview = _received_overview()
    msg = HubMessage("r2", "overview", OVERVIEW_TYPE, time.time(), overview, "telemetry")
    frame = json.loads(str(frame_of(msg)))
    assert frame["msgtype"] == OVERVIEW_TYPE and frame["data"]["hcm_state"] == 10
    assert frame["data"]["battery_voltage"] is None  # NaN: not known
    path = tmp_path / "overview.mcap"

    async def record() -> None:
        hub = Hub()
        hub.bind(asyncio.get_running_loop())
        recording = HubRecording(hub, path, "test")
        hub.publish(msg)
        status = await recording.stop()
        assert status.messages == 1 and status.skipped == 0

    asyncio.run(record())
    with LogReader(path) as log:
        (channel,) = log.channels
        assert (channel.robot_id, channel.topic, channel.typename) == ("r2", "overview", OVERVIEW_TYPE)
        (item,) = log.messages()
        assert schemas.to_dict(item.msg) == schemas.to_dict(overview) and math.isnan(item.msg.battery_voltage)
        schema = log.schema(channel.channel_id)
        assert schema is not None and "float32 hottest_servo_temperature" in schema.data.decode()


def test_replay_shows_overviews_of_earlier_and_this_version(tmp_path: Path) -> None:
    folder = tmp_path / "rec"
    folder.mkdir()
    current = _received_overview()
    with LogWriter(folder / "overviews.mcap") as writer:
        for k in range(3):
            t = T0 + k * 100_000_000
            writer.write("r1", "overview", schemas.make("std_msgs/msg/String", data=json.dumps(LEGACY)), log_time_ns=t)
            writer.write("r2", "overview", current, log_time_ns=t + 1)
            writer.write("r3", "overview", schemas.make("std_msgs/msg/String", data="not an overview"),
                         log_time_ns=t + 2)
    with dashboard_server(["--no-live", "--no-telemetry", "--recordings", str(folder)], tmp_path) as server:
        _post(server, "open", {"path": "overviews.mcap"})
        frames = asyncio.run(_collect(server.ws_url, [{"robot": "*", "topic": "overview"}],
                                      lambda fs: {f["robot"] for f in fs} >= {"replay.r1", "replay.r2"}
                                      and len(fs) >= 6,
                                      action=lambda: _post(server, "play")))
        wait_for(lambda: server.http.get(f"{server.url}/api/replay").json()["state"] == "ended", timeout=20,
                 what="replay ended")
        status = server.http.get(f"{server.url}/api/replay").json()
    assert {f["msgtype"] for f in frames} == {OVERVIEW_TYPE}
    assert "replay.r3" not in {f["robot"] for f in frames} and status["skipped"] == 3  # not an overview: left out
    old = next(f["data"] for f in frames if f["robot"] == "replay.r1")
    assert old == LEGACY
    new = next(f["data"] for f in frames if f["robot"] == "replay.r2")
    assert new == schemas.to_dict(current) and new["pose_x"] == -2.0 and new["hottest_servo"] == "RKnee"
    assert math.isnan(current.battery_voltage) and new["battery_voltage"] is None
