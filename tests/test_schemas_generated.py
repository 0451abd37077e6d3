"""The checked-in message classes are what the .msg files give, and the typestore decodes into exactly them."""

from __future__ import annotations

import numpy as np
import pytest

import schemas
from schemas import codec, generate, messages, std


def test_checked_in_module_is_what_the_definition_files_give() -> None:
    # after changing a .msg/.action/.srv file: python -m schemas.generate
    assert generate.MODULE.read_text() == generate.module_text()
    assert generate.main(["--check"]) == 0


def test_every_own_type_has_its_class_and_short_name() -> None:
    store = codec.typestore()
    # our packages, and the standard services rosbags lacks (rcl_interfaces' parameter services)
    # (without the wrappers of ROS 2's action protocol, which wire.ros2.actions adds to the store when first used)
    protocol = ("_SendGoal_", "_GetResult_", "_FeedbackMessage")
    own = [name for name in store.types if (name.split("/")[0] in codec.OWN_PACKAGES or name in messages.FIELDDEFS)
           and not any(part in name for part in protocol)]
    assert len(own) == len(messages.FIELDDEFS) > 40
    assert "rcl_interfaces/srv/SetParameters_Request" in own
    for name in own:
        cls = store.types[name]
        assert cls is getattr(messages, generate.short_name(name))
        assert cls.__msgtype__ == name


def test_decode_returns_the_generated_and_standard_classes() -> None:
    state = schemas.make(messages.RobotControlState, state=messages.RobotControlState.FALLEN)
    back = schemas.decode(schemas.encode(state), messages.RobotControlState)
    assert type(back) is messages.RobotControlState
    assert back.state == 2
    joints = schemas.make(std.JointState, name=["HeadPan"], position=[0.25])
    assert isinstance(joints.position, np.ndarray)
    back_joints = schemas.decode(schemas.encode(joints), "sensor_msgs/msg/JointState")
    assert type(back_joints) is std.JointState
    assert back_joints.name == ["HeadPan"]
    assert type(back_joints.header.stamp) is std.Time


def test_a_class_and_its_type_name_make_the_same_message() -> None:
    by_class = schemas.make(messages.GameState, own_score=3)
    by_name = schemas.make("humanoid_league_msgs/msg/GameState", own_score=3)
    assert schemas.encode(by_class) == schemas.encode(by_name)


def test_a_foreign_class_is_refused() -> None:
    from dataclasses import dataclass
    from typing import ClassVar

    @dataclass
    class Impostor:
        state: int
        __msgtype__: ClassVar[str] = "humanoid_league_msgs/msg/RobotControlState"

    with pytest.raises(schemas.SchemaError, match="not the typestore's class"):
        schemas.make(Impostor)


def test_a_stale_module_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(messages, "SOURCES_SHA256", "0" * 64)
    codec.typestore.cache_clear()
    try:
        with pytest.raises(schemas.SchemaError, match=r"python -m schemas\.generate"):
            codec.typestore()
    finally:
        monkeypatch.undo()
        codec.typestore.cache_clear()
    assert codec.typestore().types["pitchside_msgs/msg/ServoHealth"] is messages.ServoHealth
