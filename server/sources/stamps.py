"""Reading a message's header stamp straight from its CDR bytes, so the hub can stamp without decoding."""

from __future__ import annotations

import functools
import struct
import time

from schemas.codec import SchemaError, full_name, typestore

_STAMP = struct.Struct("<iI")


@functools.cache
def starts_with_header(typename: str) -> bool:
    try:
        fields = typestore().fielddefs[full_name(typename)][1]
    except (SchemaError, KeyError):
        return False
    return bool(fields) and fields[0][0] == "header" and fields[0][1][1] == "std_msgs/msg/Header"


def stamp_of(cdr: bytes, typename: str) -> float:
    """The header stamp in seconds (little-endian CDR), or now if the type has no header or the stamp is zero."""
    if len(cdr) >= 12 and cdr[1] == 1 and starts_with_header(typename):
        sec, nanosec = _STAMP.unpack_from(cdr, 4)
        if sec or nanosec:
            return sec + nanosec * 1e-9
    return time.time()
