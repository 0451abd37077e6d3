"""The servo bus's messages' own CDR path (schemas/sensor_cdr.py) against rosbags, which encodes every other type:
the same bytes, the same messages, and for anything malformed the same verdict."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import schemas
from schemas import sensor_cdr
from schemas.codec import SchemaError, typestore
from schemas.std import Header, Imu, JointState, Quaternion, Vector3

TYPENAME = "sensor_msgs/msg/JointState"
names = st.lists(st.text(max_size=12), max_size=24)
floats = st.floats(allow_nan=False, width=64)
arrays = st.lists(floats, max_size=24).map(lambda v: np.array(v, dtype=np.float64))


def by_rosbags_encode(msg: JointState | Imu) -> bytes:
    return bytes(typestore().serialize_cdr(msg, msg.__msgtype__))


def by_rosbags_decode(data: bytes, typename: str = TYPENAME) -> JointState:
    return typestore().deserialize_cdr(data, typename)


def refused_as_by_rosbags(msg: JointState | Imu) -> None:
    """Encoding fails with rosbags' own error."""
    with pytest.raises(Exception) as ours:
        schemas.encode(msg)
    with pytest.raises(Exception) as theirs:
        by_rosbags_encode(msg)
    assert type(ours.value) is type(theirs.value)


def same(a: JointState, b: JointState) -> None:
    assert (a.header.stamp.sec, a.header.stamp.nanosec, a.header.frame_id, a.name) == \
        (b.header.stamp.sec, b.header.stamp.nanosec, b.header.frame_id, b.name)
    for field in ("position", "velocity", "effort"):
        x, y = getattr(a, field), getattr(b, field)
        assert x.dtype == y.dtype == np.float64
        np.testing.assert_array_equal(x, y)


@settings(max_examples=300, deadline=None)
@given(st.integers(-2**31, 2**31 - 1), st.integers(0, 2**32 - 1), st.text(max_size=9), names, arrays, arrays,
       arrays)
def test_bytes_and_messages_are_rosbags(sec: int, nanosec: int, frame: str, joint_names: list[str],
                                        position: np.ndarray, velocity: np.ndarray, effort: np.ndarray) -> None:
    msg = schemas.make(JointState, header=Header(stamp=schemas.std.Time(sec=sec, nanosec=nanosec), frame_id=frame),
                       name=joint_names, position=position, velocity=velocity, effort=effort)
    data = schemas.encode(msg)
    assert data == by_rosbags_encode(msg)
    for _ in range(2):  # the second time the names come from what the first one kept
        decoded = schemas.decode(data, JointState)
        same(decoded, by_rosbags_decode(data))
        same(decoded, msg)


def test_a_robots_names_are_read_from_the_kept_list_but_each_message_gets_its_own() -> None:
    urdf_names = ["HeadPan", "HeadTilt", "LAnklePitch", "LAnkleRoll", "LElbow", "LHipPitch", "LHipRoll", "LHipYaw",
                  "LKnee", "LShoulderPitch", "LShoulderRoll", "RAnklePitch", "RAnkleRoll", "RElbow", "RHipPitch",
                  "RHipRoll", "RHipYaw", "RKnee", "RShoulderPitch", "RShoulderRoll"]
    values = np.linspace(-1.0, 1.0, len(urdf_names))
    msg = schemas.make(JointState, header=schemas.header("", 12.5), name=urdf_names, position=values,
                       velocity=values, effort=values)
    first = schemas.decode(schemas.encode(msg), JointState)
    second = schemas.decode(schemas.encode(msg), JointState)
    assert first.name == second.name == urdf_names and first.name is not second.name
    first.name.append("changed")  # against the rule, but it must not reach the next message
    assert schemas.decode(schemas.encode(msg), JointState).name == urdf_names


@pytest.mark.parametrize("field", ["position", "velocity", "effort"])
def test_arrays_this_path_does_not_take_go_to_rosbags(field: str) -> None:
    msg = schemas.make(JointState, header=schemas.header("base", 1.0), name=["a", "b", "c", "d"],
                       position=np.arange(4.0), velocity=np.arange(4.0), effort=np.arange(4.0))
    strided = np.arange(8.0)[::2]  # not contiguous
    setattr(msg, field, strided)
    assert sensor_cdr.encode_joint_state(msg) is None
    refused_as_by_rosbags(msg)
    setattr(msg, field, np.arange(4.0).astype(">f8"))  # big-endian values: rosbags writes them as they are
    assert sensor_cdr.encode_joint_state(msg) is None
    assert schemas.encode(msg) == by_rosbags_encode(msg)


def verdict(data: bytes, typename: str = TYPENAME) -> JointState | Imu | str:
    try:
        return by_rosbags_decode(data, typename)
    except Exception:
        return "refused"


def damaged(good: bytes, seed: int) -> list[bytes]:
    """Every truncation, padding added, and 3000 copies with one to three bytes changed."""
    rng = np.random.default_rng(seed)
    cases = [good[:n] for n in range(len(good))] + [good + b"\0" * n for n in range(1, 9)]
    for _ in range(3000):
        flipped = bytearray(good)
        for i in rng.integers(0, len(good), size=rng.integers(1, 4)):
            flipped[i] = int(rng.integers(0, 256))
        cases.append(bytes(flipped))
    return cases


def test_every_truncation_and_flipped_byte_gets_rosbags_verdict() -> None:
    msg = schemas.make(JointState, header=schemas.header("odom", 3.25), name=["HeadPan", "LKnee", "é"],
                       position=np.array([0.1, 0.2, 0.3]), velocity=np.array([]), effort=np.array([1.0, 2.0, 3.0]))
    for data in damaged(schemas.encode(msg), 7):
        expected = verdict(data)
        if expected == "refused":
            with pytest.raises(SchemaError):
                schemas.decode(data, JointState)
        else:
            same(schemas.decode(data, JointState), expected)


def same_imu(a: Imu, b: Imu) -> None:
    assert (a.header.stamp.sec, a.header.stamp.nanosec, a.header.frame_id) == \
        (b.header.stamp.sec, b.header.stamp.nanosec, b.header.frame_id)
    for part in ("orientation", "angular_velocity", "linear_acceleration"):
        x, y = getattr(a, part), getattr(b, part)
        assert type(x) is type(y)
        for axis in ("x", "y", "z", "w") if part == "orientation" else ("x", "y", "z"):
            assert type(getattr(x, axis)) is type(getattr(y, axis)) is float
            np.testing.assert_array_equal(getattr(x, axis), getattr(y, axis))
        cx, cy = getattr(a, f"{part}_covariance"), getattr(b, f"{part}_covariance")
        assert cx.dtype == cy.dtype == np.float64 and cx.shape == cy.shape == (9,)
        np.testing.assert_array_equal(cx, cy)


def make_imu(sec: int, nanosec: int, frame: str, values: list[float]) -> Imu:
    v = iter(values)
    return schemas.make(
        Imu, header=Header(stamp=schemas.std.Time(sec=sec, nanosec=nanosec), frame_id=frame),
        orientation=Quaternion(x=next(v), y=next(v), z=next(v), w=next(v)),
        orientation_covariance=np.array([next(v) for _ in range(9)]),
        angular_velocity=Vector3(x=next(v), y=next(v), z=next(v)),
        angular_velocity_covariance=np.array([next(v) for _ in range(9)]),
        linear_acceleration=Vector3(x=next(v), y=next(v), z=next(v)),
        linear_acceleration_covariance=np.array([next(v) for _ in range(9)]))


@settings(max_examples=300, deadline=None)
@given(st.integers(-2**31, 2**31 - 1), st.integers(0, 2**32 - 1), st.text(max_size=9),
       st.lists(floats, min_size=37, max_size=37))
def test_imu_bytes_and_messages_are_rosbags(sec: int, nanosec: int, frame: str, values: list[float]) -> None:
    msg = make_imu(sec, nanosec, frame, values)
    data = schemas.encode(msg)
    assert data == by_rosbags_encode(msg)
    decoded = schemas.decode(data, Imu)
    same_imu(decoded, by_rosbags_decode(data, Imu.__msgtype__))
    same_imu(decoded, msg)


def test_imu_covariances_this_path_does_not_take_go_to_rosbags() -> None:
    msg = make_imu(1, 2, "imu_frame", [float(i) for i in range(37)])
    msg.angular_velocity_covariance = np.arange(9, dtype=np.float32)
    assert sensor_cdr.encode_imu(msg) is None
    refused_as_by_rosbags(msg)


def test_every_damaged_imu_gets_rosbags_verdict() -> None:
    msg = make_imu(5, 6, "imu_frame", [float(i) / 7 for i in range(37)])
    for data in damaged(schemas.encode(msg), 11):
        expected = verdict(data, Imu.__msgtype__)
        if expected == "refused":
            with pytest.raises(SchemaError):
                schemas.decode(data, Imu)
        else:
            same_imu(schemas.decode(data, Imu), expected)
