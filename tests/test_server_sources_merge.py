"""In the lab a robot's stream arrives over live Zenoh and over telemetry: the hub takes it once."""

from __future__ import annotations

import schemas
from server.hub import Hub, HubMessage
from server.sources.telemetry import TelemetrySource
from wire.telemetry.receiver import ReceivedMessage


def received(topic: str, msg: object, typename: str) -> ReceivedMessage:
    return ReceivedMessage("robot1", topic, typename, msg, schemas.encode(msg), 1.0, 1.0, 1, 1)


def test_telemetry_copy_of_a_live_stream_is_not_published_twice() -> None:
    hub = Hub()
    sub = hub.subscribe("browser")
    sub.subscribe()
    source = TelemetrySource(hub, "127.0.0.1", 0)
    state = schemas.make("humanoid_league_msgs/msg/RobotControlState", state=0)
    hub.publish(HubMessage("robot1", "robot_state", state.__msgtype__, 1.0, state, "live"))
    source._on_messages([received("robot_state", state, state.__msgtype__)])
    gamestate = schemas.make("humanoid_league_msgs/msg/GameState", game_state=3)
    source._on_messages([received("gamestate", gamestate, gamestate.__msgtype__)])
    frames = sub.drain()
    assert [(m.topic, m.source) for m in frames] == [("robot_state", "live"), ("gamestate", "telemetry")]
    assert source.shadowed == 1 and source.messages == 1
