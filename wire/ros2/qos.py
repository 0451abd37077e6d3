"""ROS 2 quality of service as rmw_zenoh writes it into liveliness tokens (``qos_to_keyexpr`` in
liveliness_utils.cpp): ``<reliability>:<durability>:<history>,<depth>:<deadline s>,<ns>:<lifespan s>,<ns>:
<liveliness>,<lease s>,<lease ns>``, every value equal to rmw_zenoh's default left empty, so a default profile is
``::,:,:,:,,``. Numbers are the rmw enum values (rmw/types.h)."""

from __future__ import annotations

import enum
from dataclasses import dataclass, fields

from wire.ros2.errors import Ros2WireError


class Reliability(enum.IntEnum):
    SYSTEM_DEFAULT = 0
    RELIABLE = 1
    BEST_EFFORT = 2
    UNKNOWN = 3
    BEST_AVAILABLE = 4


class Durability(enum.IntEnum):
    SYSTEM_DEFAULT = 0
    TRANSIENT_LOCAL = 1
    VOLATILE = 2
    UNKNOWN = 3
    BEST_AVAILABLE = 4


class History(enum.IntEnum):
    SYSTEM_DEFAULT = 0
    KEEP_LAST = 1
    KEEP_ALL = 2
    UNKNOWN = 3


class Liveliness(enum.IntEnum):
    SYSTEM_DEFAULT = 0
    AUTOMATIC = 1
    MANUAL_BY_TOPIC = 3
    UNKNOWN = 4
    BEST_AVAILABLE = 5


# RMW_DURATION_INFINITE: what rmw_zenoh takes for "no deadline / lifespan / lease"
INFINITE_S, INFINITE_NS = 9223372036, 854775807


@dataclass(frozen=True)
class QoS:
    """A resolved profile (what an entity's token carries); the defaults are rmw_zenoh's (qos.cpp)."""

    reliability: Reliability = Reliability.RELIABLE
    durability: Durability = Durability.VOLATILE
    history: History = History.KEEP_LAST
    depth: int = 42
    deadline_s: int = INFINITE_S
    deadline_ns: int = INFINITE_NS
    lifespan_s: int = INFINITE_S
    lifespan_ns: int = INFINITE_NS
    liveliness: Liveliness = Liveliness.AUTOMATIC
    liveliness_lease_s: int = INFINITE_S
    liveliness_lease_ns: int = INFINITE_NS

    def __post_init__(self) -> None:
        for field in fields(self):
            value = getattr(self, field.name)
            if isinstance(value, int) and value < 0:
                raise Ros2WireError(f"QoS {field.name} {value} is negative")


DEFAULT = QoS()
# rclcpp's and rclpy's default for a publisher or subscription: KEEP_LAST 10, reliable, volatile
DEFAULT_10 = QoS(depth=10)
# rcl's /rosout publisher (rcl_qos_profile_rosout_default): depth 1000, transient local, a lifespan of 10 s
ROSOUT = QoS(durability=Durability.TRANSIENT_LOCAL, depth=1000, lifespan_s=10, lifespan_ns=0)
# sensor data (rmw_qos_profile_sensor_data): best effort, KEEP_LAST 5
SENSOR_DATA = QoS(reliability=Reliability.BEST_EFFORT, depth=5)


def _part(value: int, default: int) -> str:
    return "" if value == default else str(int(value))


def qos_to_keyexpr(qos: QoS) -> str:
    """The token's QoS part, as rmw_zenoh writes it."""
    d = DEFAULT
    return (f"{_part(qos.reliability, d.reliability)}:{_part(qos.durability, d.durability)}:"
            f"{_part(qos.history, d.history)},{_part(qos.depth, d.depth)}:"
            f"{_part(qos.deadline_s, d.deadline_s)},{_part(qos.deadline_ns, d.deadline_ns)}:"
            f"{_part(qos.lifespan_s, d.lifespan_s)},{_part(qos.lifespan_ns, d.lifespan_ns)}:"
            f"{_part(qos.liveliness, d.liveliness)},{_part(qos.liveliness_lease_s, d.liveliness_lease_s)},"
            f"{_part(qos.liveliness_lease_ns, d.liveliness_lease_ns)}")


def _number(text: str, default: int, what: str, keyexpr: str) -> int:
    if text == "":
        return default
    if not (text.isascii() and text.isdigit()):
        raise Ros2WireError(f"QoS {keyexpr!r}: {what} {text!r} is not a non-negative whole number")
    return int(text)


def _enum(kind: type[enum.IntEnum], text: str, default: int, keyexpr: str) -> int:
    value = _number(text, default, kind.__name__.lower(), keyexpr)
    try:
        return kind(value)
    except ValueError:
        raise Ros2WireError(f"QoS {keyexpr!r}: {value} is no {kind.__name__.lower()} policy") from None


def keyexpr_to_qos(keyexpr: str) -> QoS:
    """The QoS a token's part describes (empty values are rmw_zenoh's defaults), or Ros2WireError."""
    parts = keyexpr.split(":")
    # at least as many parts as rmw_zenoh needs; more are left to later versions, as rmw_zenoh leaves them
    if len(parts) < 6:
        raise Ros2WireError(f"QoS {keyexpr!r} has {len(parts)} ':'-separated parts, not 6")
    history, deadline, lifespan, liveliness = (parts[i].split(",") for i in (2, 3, 4, 5))
    if len(history) < 2 or len(deadline) < 2 or len(lifespan) < 2 or len(liveliness) < 3:
        raise Ros2WireError(f"QoS {keyexpr!r}: history, deadline and lifespan take 2 ','-separated values, "
                            "liveliness 3")
    d = DEFAULT
    return QoS(
        reliability=Reliability(_enum(Reliability, parts[0], d.reliability, keyexpr)),
        durability=Durability(_enum(Durability, parts[1], d.durability, keyexpr)),
        history=History(_enum(History, history[0], d.history, keyexpr)),
        depth=_number(history[1], d.depth, "depth", keyexpr),
        deadline_s=_number(deadline[0], d.deadline_s, "deadline s", keyexpr),
        deadline_ns=_number(deadline[1], d.deadline_ns, "deadline ns", keyexpr),
        lifespan_s=_number(lifespan[0], d.lifespan_s, "lifespan s", keyexpr),
        lifespan_ns=_number(lifespan[1], d.lifespan_ns, "lifespan ns", keyexpr),
        liveliness=Liveliness(_enum(Liveliness, liveliness[0], d.liveliness, keyexpr)),
        liveliness_lease_s=_number(liveliness[1], d.liveliness_lease_s, "lease s", keyexpr),
        liveliness_lease_ns=_number(liveliness[2], d.liveliness_lease_ns, "lease ns", keyexpr),
    )
