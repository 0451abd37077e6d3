"""The one exception of pitchside's rmw_zenoh wire: what a key, token or attachment from the network got wrong."""

from __future__ import annotations


class Ros2WireError(ValueError):
    """A key expression, liveliness token, QoS string or attachment that does not follow rmw_zenoh's format (or a
    name that cannot be put into one); the message says which part is wrong and quotes the input."""
