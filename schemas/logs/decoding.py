"""Turning a channel's CDR payloads back into messages, whatever wrote the log.

Known pitchside/ROS 2 types whose schema text matches ours decode with the process typestore
(so messages are the same classes nodes use); any other ros2msg schema is parsed into a
private typestore, so foreign bags (rcl_interfaces/Log, test_msgs/...) still decode.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from mcap.records import Channel, Schema
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from schemas import codec
from schemas.logs.naming import full_typename

Decoder = Callable[[bytes], Any]


class UndecodableChannel(Exception):
    """The channel's schema cannot be turned into a decoder (the reason is the message)."""


def make_decoder(channel: Channel, schema: Schema | None) -> Decoder:
    """A CDR decoder for the channel; UndecodableChannel says why there is none."""
    if channel.message_encoding != "cdr":
        raise UndecodableChannel(f"message encoding {channel.message_encoding!r} is not cdr")
    if schema is None or schema.encoding != "ros2msg":
        raise UndecodableChannel(f"schema encoding {schema.encoding if schema else None!r} is not ros2msg")
    typename = full_typename(schema.name)
    try:
        parsed = get_types_from_msg(schema.data.decode(), typename)
    except Exception as exc:  # rosbags raises TypesysError, but bad text may raise others
        raise UndecodableChannel(f"schema {schema.name} does not parse: {' '.join(str(exc).split())[:160]}") from exc
    if typename not in parsed:
        raise UndecodableChannel(f"schema {schema.name} does not define {typename}")
    shared = codec.typestore()
    if all(shared.fielddefs.get(name) == definition for name, definition in parsed.items()):
        return lambda data: shared.deserialize_cdr(data, typename)
    private = get_typestore(Stores.EMPTY)
    try:
        private.register(parsed)
    except Exception as exc:
        raise UndecodableChannel(f"schema {schema.name} cannot be registered: {exc}") from exc
    return lambda data: private.deserialize_cdr(data, typename)
