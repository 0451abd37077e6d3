"""Every own and standard message type survives a CDR round trip with non-default values."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest

import schemas
from schemas import codec

OWN_TYPES = sorted(t for t in codec.typestore().types if t.split("/")[0] in codec.OWN_PACKAGES)
STANDARD_TYPES = sorted({t.type for t in schemas.TOPICS.values()} - set(OWN_TYPES))


def _filled(typename: str, seed: int = 1) -> Any:
    """A message whose every field differs from its zero value."""
    store = codec.typestore()
    values: dict[str, Any] = {}
    for i, (name, (kind, detail)) in enumerate(store.fielddefs[typename][1]):
        n = seed + i
        if kind == 1:
            base = detail[0]
            values[name] = (f"{name}-{n}" if base in ("string", "wstring") else True if base == "bool"
                            else float(n) + 0.5 if base.startswith("float") else n % 100 + 1)
        elif kind == 2:
            values[name] = _filled(detail, n)
        elif kind in (3, 4):
            sub, length = detail
            count = length or 2
            if sub[0] == 1 and sub[1][0] in codec._NUMPY_TYPES:
                values[name] = np.arange(1, count + 1) + n % 7
            elif sub[0] == 1:
                values[name] = [f"s{j}" if sub[1][0] == "string" else True for j in range(count)]
            else:
                values[name] = [_filled(sub[1], n + j) for j in range(count)]
    return codec.make(typename, **values)


def _equal(a: Any, b: Any) -> bool:
    if dataclasses.is_dataclass(a):
        return all(_equal(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a))
    if isinstance(a, np.ndarray):
        return bool(np.array_equal(a, b))
    if isinstance(a, list):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b, strict=True))
    return bool(a == b)


def test_every_thesis_message_is_defined() -> None:
    names = {t.rsplit("/", 1)[1] for t in OWN_TYPES}
    for required in ("GameState", "RobotControlState", "Animation", "PlayAnimation_Goal", "Kick_Goal",
                     "BallRelative", "BallInImage", "BallsInImage", "GoalInImage", "GoalPartsInImage",
                     "PostInImage", "BarInImage", "GoalRelative", "ObstacleInImage", "ObstaclesInImage",
                     "ObstacleRelative", "ObstaclesRelative", "LineInformationInImage", "LineSegmentInImage",
                     "LineIntersectionInImage", "LineCircleInImage", "LineInformationRelative",
                     "LineSegmentRelative", "Position2D", "Model", "HeadMode", "Strategy", "TeamData", "Speak",
                     "VisualCompassRotation", "AdditionalServoData", "ManualPenalize_Request"):
        assert required in names, required


@pytest.mark.parametrize("typename", OWN_TYPES + STANDARD_TYPES)
def test_round_trip_keeps_every_field(typename: str) -> None:
    msg = _filled(typename)
    assert not _equal(msg, codec.make(typename)) or not codec.typestore().fielddefs[typename][1]
    back = schemas.decode(schemas.encode(msg), typename)
    assert _equal(msg, back)


def test_constants_by_name() -> None:
    state = schemas.message_class("humanoid_league_msgs/msg/RobotControlState")
    assert state.FALLEN == 2 and state.HARDWARE_PROBLEM == 13
    assert schemas.constants("humanoid_league_msgs/msg/HeadMode")["LOOK_DOWN"] == 5
    assert schemas.constants("humanoid_league_msgs/msg/Strategy")["ROLE_GOALIE"] == 5
    assert schemas.constants("humanoid_league_msgs/srv/ManualPenalize_Request")["SWITCH"] == 2


def test_topic_table_types_exist() -> None:
    for topic in schemas.TOPICS.values():
        codec.full_name(topic.type)
    assert schemas.TOPICS["motor_goals"].type == "trajectory_msgs/msg/JointTrajectory"
    with pytest.raises(KeyError, match="not in the topic table"):
        schemas.topic("no_such_topic")


def test_garbage_payload_raises_schema_error() -> None:
    with pytest.raises(schemas.SchemaError, match="not a valid"):
        schemas.decode(b"\x00\x01\x00\x00\xff\xff\xff\x7f", "sensor_msgs/msg/JointState")


def test_msgdef_contains_dependencies() -> None:
    text = schemas.msgdef("humanoid_league_msgs/msg/Model")
    assert "MSG: humanoid_league_msgs/BallRelative" in text and "MSG: geometry_msgs/Pose2D" in text


def test_unknown_field_is_refused() -> None:
    with pytest.raises(schemas.SchemaError, match="no field"):
        schemas.make("std_msgs/msg/Bool", valu=True)


def test_to_dict_has_fields_not_constants() -> None:
    msg = schemas.make("humanoid_league_msgs/msg/RobotControlState", state=2)
    assert schemas.to_dict(msg) == {"state": 2}
    state = schemas.to_dict(schemas.make("sensor_msgs/msg/JointState", name=["a"], position=[1.5]))
    assert state["position"] == [1.5] and state["header"]["stamp"] == {"sec": 0, "nanosec": 0}


def test_a_topic_defined_twice_is_refused() -> None:
    from schemas.topics import Topic, _by_name

    twice = (Topic("a", "std_msgs/msg/Bool", "one"), Topic("a", "std_msgs/msg/Bool", "two"))
    with pytest.raises(ValueError, match="defined twice"):
        _by_name(twice)


def test_field_names_are_the_fields_without_constants_for_every_type() -> None:
    from schemas.json_view import field_names

    store = codec.typestore()
    for typename, cls in store.types.items():
        assert field_names(cls) == tuple(name for name, _ in store.fielddefs[typename][1]), typename
    assert field_names(dict) is None and field_names(int) is None


def test_to_dict_is_json_ready_for_own_and_foreign_types() -> None:
    from rosbags.typesys import Stores, get_typestore

    data = schemas.to_dict(schemas.make("sensor_msgs/msg/Imu", orientation_covariance=[1.0, float("nan")] + [0.0] * 7,
                                        angular_velocity_covariance=[float("inf")] * 9))
    assert data["orientation_covariance"][:3] == [1.0, None, 0.0] and data["angular_velocity_covariance"] == [None] * 9
    big = schemas.to_dict(schemas.make("sensor_msgs/msg/CompressedImage", data=np.zeros(5000, np.uint8)))
    assert big["data"] == {"bytes": 5000}
    small = schemas.to_dict(schemas.make("sensor_msgs/msg/CompressedImage", data=np.arange(3, dtype=np.uint8)))
    assert small["data"] == [0, 1, 2]
    assert schemas.to_dict({"a": [np.float32(1.5), np.int64(2), np.bool_(True), float("nan")]}) == {
        "a": [1.5, 2, True, None]}
    # a type of another store (a ROS 2 bag's own definitions): fields by name, constants left out
    ros1 = get_typestore(Stores.ROS1_NOETIC)
    log = ros1.types["rosgraph_msgs/msg/Log"](header=ros1.types["std_msgs/msg/Header"](
        seq=1, stamp=ros1.types["builtin_interfaces/msg/Time"](sec=2, nanosec=3), frame_id="f"),
        level=2, name="n", msg="m", file="x.py", function="f", line=7, topics=["/a"])
    assert schemas.to_dict(log) == {"header": {"seq": 1, "stamp": {"sec": 2, "nanosec": 3}, "frame_id": "f"},
                                    "level": 2, "name": "n", "msg": "m", "file": "x.py", "function": "f",
                                    "line": 7, "topics": ["/a"]}


def test_numeric_fields_name_joints_and_skip_headers() -> None:
    from schemas.numeric import numeric_values

    state = schemas.make("sensor_msgs/msg/JointState", name=["HeadPan", "LKnee"], position=[0.5, -1.0],
                         velocity=[], effort=[])
    assert [(f.path, f.name, f.label, f.value) for f in numeric_values(state)] == [
        ("position/0", "position/HeadPan", "position/0 (HeadPan)", 0.5),
        ("position/1", "position/LKnee", "position/1 (LKnee)", -1.0)]
    image = schemas.make("sensor_msgs/msg/CompressedImage", data=np.zeros(100, np.uint8))
    assert list(numeric_values(image)) == []  # a long byte array is no plot


def test_the_overview_and_servo_health_are_rows_of_the_topic_table() -> None:
    assert schemas.topic("overview").type == "pitchside_msgs/msg/RobotOverview"
    assert schemas.topic("servo_health").type == "pitchside_msgs/msg/ServoHealth"
    assert schemas.constants("pitchside_msgs/msg/RobotOverview") == {"UNKNOWN": 255, "NEVER_MS": 65535}
    assert {t.name for t in schemas.TOPICS.values() if t.event} == {
        "animation", "motor_torque", "speak", "cmd_vel", "walk_odometry", "walk_motor_goals", "head_motor_goals",
        "record_motor_goals", "motor_goals", "team_data", "rosout", "whistle", "robot_description", "tf_static"}
