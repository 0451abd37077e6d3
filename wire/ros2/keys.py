"""rmw_zenoh's data key expressions: ``<domain>/<fully qualified name>/<pkg>::<kind>::dds_::<Type>_/RIHS01_<hash>``.

The domain keeps ROS_DOMAIN_ID apart on one Zenoh network; the DDS type name and the type hash keep publishers and
subscribers of different types (or different versions of one type) apart, as rmw_zenoh_cpp 0.2.x (Jazzy) writes
them (``TopicInfo`` in liveliness_utils.cpp). Services use the same layout with ``::srv::``.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass

from wire.ros2.errors import Ros2WireError

DEFAULT_DOMAIN_ID = 0
# ROS 2 names: tokens of letters, digits and '_' (a token not starting with a digit), joined by '/'
_NAME_TOKEN = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_HASH = re.compile(r"^RIHS01_[0-9a-f]{64}$")
_DDS_TYPE = re.compile(r"^([A-Za-z0-9_]+)::(msg|srv|action)::dds_::([A-Za-z0-9_]+)_$")
_ROS_TYPE = re.compile(r"^([A-Za-z0-9_]+)/(msg|srv|action)/([A-Za-z0-9_]+)$")


def domain_id_from_env(environ: dict[str, str] | None = None) -> int:
    """ROS_DOMAIN_ID as ROS 2 reads it (0 when unset or empty)."""
    text = (os.environ if environ is None else environ).get("ROS_DOMAIN_ID", "").strip()
    if not text:
        return DEFAULT_DOMAIN_ID
    if not (text.isascii() and text.isdigit()):
        raise Ros2WireError(f"ROS_DOMAIN_ID {text!r} is not a non-negative whole number")
    return int(text)


def fully_qualified_name(namespace: str, name: str) -> str:
    """``/robot1`` + ``joint_states`` -> ``/robot1/joint_states``; an absolute name keeps its own namespace."""
    if name.startswith("/"):
        full = name
    else:
        full = "/".join(part for part in (namespace.strip("/"), name) if part)
        full = "/" + full
    check_name(full)
    return full


def check_name(full_name: str) -> str:
    """A fully qualified ROS 2 name (``/`` or ``/a/b``), or Ros2WireError saying what is wrong with it."""
    if full_name == "/":
        return full_name
    if not full_name.startswith("/") or full_name.endswith("/"):
        raise Ros2WireError(f"{full_name!r} is not a fully qualified ROS 2 name (starts with '/', does not end in it)")
    for token in full_name[1:].split("/"):
        if not _NAME_TOKEN.match(token):
            raise Ros2WireError(f"{full_name!r}: {token!r} is not a ROS 2 name token (letters, digits, '_')")
    return full_name


def dds_type_name(ros_type: str) -> str:
    """``sensor_msgs/msg/JointState`` -> ``sensor_msgs::msg::dds_::JointState_`` (services: ``pkg/srv/X``)."""
    match = _ROS_TYPE.match(ros_type)
    if match is None:
        raise Ros2WireError(f"{ros_type!r} is not a ROS 2 type name of the form pkg/msg/Type")
    package, kind, name = match.groups()
    return f"{package}::{kind}::dds_::{name}_"


def ros_type_name(dds_type: str) -> str:
    """``sensor_msgs::msg::dds_::JointState_`` -> ``sensor_msgs/msg/JointState``."""
    match = _DDS_TYPE.match(dds_type)
    if match is None:
        raise Ros2WireError(f"{dds_type!r} is not a DDS type name of the form pkg::msg::dds_::Type_")
    package, kind, name = match.groups()
    return f"{package}/{kind}/{name}"


def check_type_hash(type_hash: str) -> str:
    if not _HASH.match(type_hash):
        raise Ros2WireError(f"{type_hash!r} is not a RIHS01 type hash (RIHS01_ and 64 lower-case hex digits)")
    return type_hash


@dataclass(frozen=True)
class TopicKey:
    """A topic's or service's data key: who may talk on it."""

    domain_id: int
    name: str  # fully qualified: /robot1/joint_states
    ros_type: str  # sensor_msgs/msg/JointState
    type_hash: str  # RIHS01_...

    def __post_init__(self) -> None:
        if self.domain_id < 0:
            raise Ros2WireError(f"domain id {self.domain_id} is negative")
        check_name(self.name)
        dds_type_name(self.ros_type)
        check_type_hash(self.type_hash)

    @property
    def keyexpr(self) -> str:
        """What rmw_zenoh publishes and subscribes on (the name without its leading and trailing '/')."""
        return f"{self.domain_id}/{self.name.strip('/')}/{dds_type_name(self.ros_type)}/{self.type_hash}"


def parse_topic_key(keyexpr: str) -> TopicKey:
    """The TopicKey of a data key expression, or Ros2WireError."""
    parts = keyexpr.split("/")
    if len(parts) < 4:
        raise Ros2WireError(f"data key {keyexpr!r} has {len(parts)} parts; rmw_zenoh's have at least 4: "
                            "<domain>/<name...>/<type>/<hash>")
    domain, *name, dds_type, type_hash = parts
    if not (domain.isascii() and domain.isdigit()):
        raise Ros2WireError(f"data key {keyexpr!r}: domain {domain!r} is not a number")
    return TopicKey(int(domain), "/" + "/".join(name), ros_type_name(dds_type), check_type_hash(type_hash))
