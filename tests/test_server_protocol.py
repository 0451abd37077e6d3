"""The browser wire protocol: client requests are outside input (fuzzed), frames round-trip."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import schemas
from server.hub import HubMessage
from server.protocol import (
    ProtocolError,
    batch_frame,
    frame_of,
    parse_client_frame,
    split_binary_frame,
    unbatch,
)

JSON = st.recursive(st.none() | st.booleans() | st.floats(allow_nan=False) | st.integers() | st.text(),
                    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(), inner, max_size=4),
                    max_leaves=12)


@given(st.text())
def test_any_text_is_a_request_or_a_protocol_error(text: str) -> None:
    try:
        request = parse_client_frame(text)
    except ProtocolError:
        return
    assert request["op"] in ("subscribe", "unsubscribe", "ping")


@given(st.dictionaries(st.sampled_from(["op", "robot", "topic", "max_hz", "id"]), JSON))
def test_any_json_object_is_a_request_or_a_protocol_error(obj: dict) -> None:  # type: ignore[type-arg]
    try:
        request = parse_client_frame(json.dumps(obj))
    except ProtocolError as exc:
        assert str(exc)
        return
    if request["op"] == "subscribe":
        assert isinstance(request["robot"], str) and request["max_hz"] >= 0


@given(st.binary(max_size=64))
def test_any_binary_frame_splits_or_is_a_protocol_error(data: bytes) -> None:
    try:
        meta, _ = split_binary_frame(data)
    except ProtocolError:
        return
    assert isinstance(meta, dict)


def test_requests() -> None:
    assert parse_client_frame('{"op":"subscribe","robot":"r1","topic":"joint_states","max_hz":10}') == {
        "op": "subscribe", "robot": "r1", "topic": "joint_states", "max_hz": 10.0}
    assert parse_client_frame('{"op":"subscribe"}')["topic"] == "*"
    for bad in ('{"op":"subscribe","max_hz":-1}', '{"op":"subscribe","max_hz":true}', '{"op":"jump"}', "[]",
                '{"op":"subscribe","robot":""}', "not json"):
        with pytest.raises(ProtocolError):
            parse_client_frame(bad)


def test_image_frame_round_trip_and_batches() -> None:
    jpeg = bytes(range(256)) * 40
    image = schemas.make("sensor_msgs/msg/CompressedImage", format="jpeg", data=np.frombuffer(jpeg, np.uint8))
    frame = frame_of(HubMessage("r1", "camera/image/compressed", image.__msgtype__, 12.5, image, "live"))
    assert isinstance(frame, bytes)
    meta, payload = split_binary_frame(frame)
    assert payload == jpeg
    assert meta == {"type": "image", "robot": "r1", "topic": "camera/image/compressed",
                    "msgtype": "sensor_msgs/msg/CompressedImage", "stamp": 12.5, "source": "live", "format": "jpeg"}
    state = schemas.make("humanoid_league_msgs/msg/RobotControlState", state=3)
    text = frame_of(HubMessage("r1", "robot_state", state.__msgtype__, time.time(), state, "live"))
    assert isinstance(text, str)
    frames = unbatch(json.loads(batch_frame([text, text])))
    assert [f["data"] for f in frames] == [{"state": 3}, {"state": 3}]


def test_message_data_has_fields_not_constants_and_no_nan() -> None:
    imu = schemas.make("sensor_msgs/msg/Imu", orientation_covariance=[float("nan")] * 9)
    data = schemas.to_dict(imu)
    assert data["orientation_covariance"] == [None] * 9 or all(v != v for v in data["orientation_covariance"])
    frame = frame_of(HubMessage("r1", "imu/data", imu.__msgtype__, 0.0, imu, "live"))
    assert "NaN" not in frame and json.loads(frame)["data"]["orientation_covariance"] == [None] * 9
    obstacles = schemas.make("humanoid_league_msgs/msg/ObstaclesInImage", obstacles=[
        schemas.make("humanoid_league_msgs/msg/ObstacleInImage", color=2)])
    assert schemas.to_dict(obstacles)["obstacles"][0] == {
        "color": 2, "player_number": 0, "top_left": {"x": 0.0, "y": 0.0, "z": 0.0}, "height": 0, "width": 0,
        "confidence": 0.0}
