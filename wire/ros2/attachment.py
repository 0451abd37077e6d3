"""The attachment rmw_zenoh puts on every sample, request and reply, and drops samples without.

int64 sequence number (from 1, per entity), int64 source timestamp (ns since the Unix epoch), then the GID as
zenoh-ext serialises a std::array<uint8_t, 16>: its length as a LEB128 varint (one byte, 16), then 16 bytes; all
little-endian (``AttachmentData`` in attachment_helpers.cpp; docs/design.md "Publishers").
"""

from __future__ import annotations

import itertools
import struct
import time
from dataclasses import dataclass

from wire.ros2.errors import Ros2WireError
from wire.ros2.liveliness import GID_SIZE

_HEAD = struct.Struct("<qqB")
SIZE = _HEAD.size + GID_SIZE  # 33


@dataclass(frozen=True)
class Attachment:
    sequence_number: int
    source_timestamp_ns: int
    gid: bytes

    def __post_init__(self) -> None:
        if len(self.gid) != GID_SIZE:
            raise Ros2WireError(f"a GID has {GID_SIZE} bytes, not {len(self.gid)}")

    def encode(self) -> bytes:
        return _HEAD.pack(self.sequence_number, self.source_timestamp_ns, GID_SIZE) + self.gid


def decode_attachment(data: bytes | bytearray | memoryview) -> Attachment:
    """The attachment of a sample, or Ros2WireError if it is not one rmw_zenoh wrote."""
    raw = bytes(data)
    if len(raw) != SIZE:
        raise Ros2WireError(f"attachment of {len(raw)} bytes; rmw_zenoh's has {SIZE}")
    sequence_number, timestamp_ns, gid_length = _HEAD.unpack_from(raw)
    if gid_length != GID_SIZE:
        raise Ros2WireError(f"attachment GID length {gid_length}, not {GID_SIZE}")
    return Attachment(sequence_number, timestamp_ns, raw[_HEAD.size:])


class AttachmentStamper:
    """The attachments of one publisher's samples: sequence numbers from 1, the time of each, its GID."""

    def __init__(self, gid: bytes) -> None:
        if len(gid) != GID_SIZE:
            raise Ros2WireError(f"a GID has {GID_SIZE} bytes, not {len(gid)}")
        self.gid = gid
        self._numbers = itertools.count(1)  # next() on a count is atomic: publishers on several threads are safe

    def next(self) -> bytes:
        return _HEAD.pack(next(self._numbers), time.time_ns(), GID_SIZE) + self.gid
