"""CDR of sensor_msgs/JointState without a Python call per joint name: the one message every simulated robot's
servo bus sends 100 times a second to another process (8 robots: 800 encodes in the world, 800 decodes in the
robots' processes). rosbags (schemas.codec) encodes and decodes each name on its own, more than the rest of the
message together; a robot's names are the same in every message, so here their CDR is made once per list of
names, and read back by comparing bytes with the lists seen before.

The bytes and messages are exactly rosbags' (tests/test_joint_state_cdr.py compares both on random messages and
real bags). What this path does not take (big-endian CDR, an array that is not contiguous float64, anything
malformed) it leaves to rosbags by returning None, so errors read the same as for every other type.
"""

from __future__ import annotations

import struct
from typing import Any

import numpy as np

TYPENAME = "sensor_msgs/msg/JointState"
_LITTLE_ENDIAN_CDR = b"\x00\x01\x00\x00"  # encapsulation: CDR, little endian, no options
_STAMP = struct.Struct("<iI")
_U32 = struct.Struct("<I")
_KEPT = 16  # lists of names remembered each way: a process sees a few robots' lists, usually one
_MAX_SEQUENCE = 2**31  # rosbags' max_sequence_length unless a typestore says less (checked by the caller)

_blocks_out: dict[tuple[str, ...], bytes] = {}
# (CDR of a list of names from its count to the padding after its last name, the names); swapped whole, never
# changed in place: Zenoh threads decode at the same time
_blocks_in: tuple[tuple[bytes, tuple[str, ...]], ...] = ()


def _string(text: str) -> bytes:
    """A CDR string written at a 4-aligned position, padded to the next one: length with the NUL, bytes, NUL."""
    data = text.encode()
    return _U32.pack(len(data) + 1) + data + b"\0" * (4 - len(data) % 4)


def _names_block(names: list[str]) -> bytes:
    key = tuple(names)
    block = _blocks_out.get(key)
    if block is None:
        if len(_blocks_out) >= _KEPT:
            _blocks_out.clear()
        block = _blocks_out[key] = _U32.pack(len(key)) + b"".join([_string(n) for n in key])
    return block


def encode(msg: Any) -> bytes | None:
    """The CDR of a JointState, or None if it holds what this path does not take (rosbags then encodes it)."""
    try:
        header = msg.header
        out = bytearray(_LITTLE_ENDIAN_CDR)
        out += _STAMP.pack(header.stamp.sec, header.stamp.nanosec)
        out += _string(header.frame_id)  # at position 8 (positions count after the encapsulation): 4-aligned
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


def decode(data: bytes, cls: type, header_cls: type, time_cls: type, max_sequence: int = _MAX_SEQUENCE) -> Any:
    """A JointState from little-endian CDR, or None for anything else (rosbags then decodes it, or says why not)."""
    if data[:4] != _LITTLE_ENDIAN_CDR:
        return None
    try:
        sec, nanosec = _STAMP.unpack_from(data, 4)
        frame_id, pos = _read_string(data, 12)
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
    return cls(header=header_cls(stamp=time_cls(sec=sec, nanosec=nanosec), frame_id=frame_id), name=list(names),
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
