"""CDR of the two messages a servo bus sends 100 times a second, sensor_msgs/JointState and sensor_msgs/Imu,
without rosbags' Python call per field: with 8 simulated robots the world encodes 800 of each a second and the
robots' processes decode them. rosbags (schemas.codec) encodes every other type.

JointState: rosbags encodes and decodes each joint name on its own, more than the rest of the message together; a
robot's names are the same in every message, so here their CDR is made once per list of names, and read back by
comparing bytes with the lists seen before. Imu: after its header it is 37 float64 in a row (orientation,
angular velocity, linear acceleration and their covariances), packed and unpacked at once.

The bytes and messages are exactly rosbags' (tests/test_sensor_cdr.py compares both on random messages, every
truncation and damaged bytes). What this path does not take (big-endian CDR, an array that is not contiguous
float64, anything malformed) it leaves to rosbags by returning None, so errors read the same as for every type.
"""

from __future__ import annotations

import struct
from typing import Any

import numpy as np

JOINT_STATE = "sensor_msgs/msg/JointState"
IMU = "sensor_msgs/msg/Imu"
_LITTLE_ENDIAN_CDR = b"\x00\x01\x00\x00"  # encapsulation: CDR, little endian, no options
_STAMP = struct.Struct("<iI")
_U32 = struct.Struct("<I")
_KEPT = 16  # lists of names remembered each way: a process sees a few robots' lists, usually one

_blocks_out: dict[tuple[str, ...], bytes] = {}
# (CDR of a list of names from its count to the padding after its last name, the names); swapped whole, never
# changed in place: Zenoh threads decode at the same time
_blocks_in: tuple[tuple[bytes, tuple[str, ...]], ...] = ()


def _header(header: Any) -> bytearray:
    """The encapsulation and a std_msgs/Header, ending right after the frame id's NUL (no padding)."""
    return bytearray(_LITTLE_ENDIAN_CDR + _STAMP.pack(header.stamp.sec, header.stamp.nanosec)
                     + _string(header.frame_id, padded=False))


def _read_header(data: bytes) -> tuple[tuple[int, int], str, int]:
    """(sec, nanosec), frame id, and the position after the frame id's NUL."""
    stamp = _STAMP.unpack_from(data, 4)
    frame_id, pos = _read_string(data, 12)
    return stamp, frame_id, pos


def _string(text: str, padded: bool = True) -> bytes:
    """A CDR string written at a 4-aligned position: length with the NUL, bytes, NUL, and (``padded``) the padding
    to the next 4-aligned position."""
    data = text.encode()
    return _U32.pack(len(data) + 1) + data + b"\0" * ((4 - len(data) % 4) if padded else 1)


def _names_block(names: list[str]) -> bytes:
    key = tuple(names)
    block = _blocks_out.get(key)
    if block is None:
        if len(_blocks_out) >= _KEPT:
            _blocks_out.clear()
        block = _blocks_out[key] = _U32.pack(len(key)) + b"".join([_string(n) for n in key])
    return block


def encode_joint_state(msg: Any) -> bytes | None:
    """The CDR of a JointState, or None if it holds what this path does not take (rosbags then encodes it)."""
    try:
        out = _header(msg.header)
        out += b"\0" * (-len(out) % 4)  # to 4 (the encapsulation's 4 bytes change nothing)
        out += _names_block(msg.name)
        for values in (msg.position, msg.velocity, msg.effort):
            if not (isinstance(values, np.ndarray) and values.dtype == np.float64 and values.ndim == 1
                    and values.flags.c_contiguous):
                return None
            out += _U32.pack(len(values))
            if len(values):
                out += b"\0" * ((len(out) - 4) % 8)  # to 8: the count ends 4-aligned
                out += values.tobytes()
    except (struct.error, TypeError, AttributeError, UnicodeEncodeError):
        return None
    return bytes(out)


def decode_joint_state(data: bytes, cls: type, header_cls: type, time_cls: type, max_sequence: int) -> Any:
    """A JointState from little-endian CDR, or None for anything else (rosbags then decodes it, or says why not)."""
    if data[:4] != _LITTLE_ENDIAN_CDR:
        return None
    try:
        stamp, frame_id, pos = _read_header(data)
        pos += -(pos - 4) % 4
        names, pos = _read_names(data, pos, max_sequence)
        arrays = []
        for _ in range(3):
            (count,) = _U32.unpack_from(data, pos)
            pos += 4
            if count > max_sequence:
                return None
            if count:
                pos += -(pos - 4) % 8
            if pos + 8 * count > len(data):
                return None
            arrays.append(np.frombuffer(data, dtype=np.float64, count=count, offset=pos))
            pos += 8 * count
    except (struct.error, UnicodeDecodeError, ValueError):
        return None
    if pos + 3 < len(data):  # rosbags allows the padding to the next 4, no more
        return None
    return cls(header=header_cls(stamp=time_cls(sec=stamp[0], nanosec=stamp[1]), frame_id=frame_id), name=list(names),
               position=arrays[0], velocity=arrays[1], effort=arrays[2])


def _read_string(data: bytes, pos: int) -> tuple[str, int]:
    (length,) = _U32.unpack_from(data, pos)
    end = pos + 4 + length
    if length < 1 or end > len(data) or data[end - 1] != 0:
        raise ValueError(f"not a CDR string at {pos}")
    return data[pos + 4:end - 1].decode(), end


def _read_names(data: bytes, pos: int, max_sequence: int) -> tuple[tuple[str, ...], int]:
    """The names at ``pos`` (4-aligned) and where the next field begins: a list seen before by its bytes."""
    global _blocks_in
    for block, names in _blocks_in:
        if data.startswith(block, pos):
            return names, pos + len(block)
    start = pos
    (count,) = _U32.unpack_from(data, pos)
    pos += 4
    if count > max_sequence or pos + 5 * count > len(data):
        raise ValueError(f"{count} names do not fit")
    found = []
    for _ in range(count):
        pos += -(pos - 4) % 4
        name, pos = _read_string(data, pos)
        found.append(name)
    pos += -(pos - 4) % 4
    if pos > len(data):
        raise ValueError("names run past the end")
    names = tuple(found)
    _blocks_in = (*_blocks_in[-(_KEPT - 1):], (bytes(data[start:pos]), names))
    return names, pos


_IMU_VALUES = struct.Struct("<37d")  # orientation 4, covariance 9, angular velocity 3, 9, linear acceleration 3, 9


def encode_imu(msg: Any) -> bytes | None:
    """The CDR of an Imu, or None if it holds what this path does not take (rosbags then encodes it)."""
    try:
        out = _header(msg.header)
        covariances = (msg.orientation_covariance, msg.angular_velocity_covariance, msg.linear_acceleration_covariance)
        if not all(isinstance(c, np.ndarray) and c.dtype == np.float64 and c.shape == (9,) for c in covariances):
            return None
        o, w, a = msg.orientation, msg.angular_velocity, msg.linear_acceleration
        out += b"\0" * ((4 - len(out)) % 8)  # to 8, counted after the 4 bytes of encapsulation
        out += _IMU_VALUES.pack(o.x, o.y, o.z, o.w, *covariances[0].tolist(), w.x, w.y, w.z,
                                *covariances[1].tolist(), a.x, a.y, a.z, *covariances[2].tolist())
    except (struct.error, TypeError, AttributeError, UnicodeEncodeError):
        return None
    return bytes(out)


def decode_imu(data: bytes, classes: tuple[type, type, type, type, type]) -> Any:
    """An Imu from little-endian CDR, or None for anything else (rosbags then decodes it, or says why not).
    classes: the typestore's Imu, Header, Time, Quaternion and Vector3."""
    if data[:4] != _LITTLE_ENDIAN_CDR:
        return None
    try:
        stamp, frame_id, pos = _read_header(data)
    except (struct.error, UnicodeDecodeError, ValueError):
        return None
    pos += -(pos - 4) % 8
    if not 0 <= len(data) - (pos + _IMU_VALUES.size) <= 3:  # rosbags allows the padding to the next 4, no more
        return None
    values = np.frombuffer(data, dtype=np.float64, count=37, offset=pos)
    ox, oy, oz, ow = values[0:4].tolist()
    wx, wy, wz = values[13:16].tolist()
    ax, ay, az = values[25:28].tolist()
    imu, header, time, quaternion, vector3 = classes
    return imu(header=header(stamp=time(sec=stamp[0], nanosec=stamp[1]), frame_id=frame_id),
               orientation=quaternion(x=ox, y=oy, z=oz, w=ow), orientation_covariance=values[4:13],
               angular_velocity=vector3(x=wx, y=wy, z=wz), angular_velocity_covariance=values[16:25],
               linear_acceleration=vector3(x=ax, y=ay, z=az), linear_acceleration_covariance=values[28:37])
