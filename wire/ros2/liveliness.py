"""rmw_zenoh's liveliness tokens: the ROS 2 graph (``ros2 node list``, ``ros2 topic list -t``, ...) is read from them.

    @ros2_lv/<domain>/<zenoh id>/<node id>/<entity id>/<NN|MP|MS|SS|SC>/<enclave>/<namespace>/<node>
        [/<topic or service name>/<DDS type>/<type hash>/<qos>]

Names are mangled (every '/' becomes '%'; an empty enclave or namespace is '%'), a node's entity id is its node
id, and the QoS is qos.qos_to_keyexpr's. As in ``Entity`` of rmw_zenoh_cpp 0.2.x's liveliness_utils.cpp.
"""

from __future__ import annotations

import enum
import hashlib
from dataclasses import dataclass

from wire.ros2.errors import Ros2WireError
from wire.ros2.keys import TopicKey, check_name, dds_type_name, ros_type_name
from wire.ros2.qos import QoS, keyexpr_to_qos, qos_to_keyexpr

ADMIN_SPACE = "@ros2_lv"
GID_SIZE = 16


class EntityKind(enum.Enum):
    NODE = "NN"
    PUBLISHER = "MP"
    SUBSCRIPTION = "MS"
    SERVICE = "SS"
    CLIENT = "SC"


def mangle(name: str) -> str:
    """A name as one key chunk: '/' -> '%' (so an empty namespace "/" is "%")."""
    return name.replace("/", "%")


def demangle(chunk: str) -> str:
    return chunk.replace("%", "/")


def subscription_keyexpr(domain_id: int) -> str:
    """Every token of a domain: what a graph cache subscribes to and queries."""
    return f"{ADMIN_SPACE}/{domain_id}/**"


@dataclass(frozen=True)
class NodeInfo:
    domain_id: int
    namespace: str  # "/" for the root namespace, else "/robot1"
    name: str
    enclave: str = "/"

    @property
    def fully_qualified_name(self) -> str:
        return self.namespace.rstrip("/") + "/" + self.name


@dataclass(frozen=True)
class Entity:
    """One node, publisher, subscription, service server or client, as its token describes it."""

    zid: str  # the Zenoh session id, lower-case hex
    node_id: int
    entity_id: int
    kind: EntityKind
    node: NodeInfo
    topic: TopicKey | None = None  # None for a node, the topic or service for the others
    qos: QoS | None = None

    def __post_init__(self) -> None:
        if (self.kind is EntityKind.NODE) != (self.topic is None):
            raise Ros2WireError(f"a {self.kind.name.lower()} entity {'has no' if self.topic else 'needs a'} topic")
        if self.topic is not None and self.topic.domain_id != self.node.domain_id:
            raise Ros2WireError(f"topic domain {self.topic.domain_id} is not the node's {self.node.domain_id}")
        if not self.node.name or "/" in self.node.name:
            raise Ros2WireError(f"node name {self.node.name!r} is empty or has a '/'")
        check_name(self.node.namespace)

    @property
    def token(self) -> str:
        """The liveliness key expression rmw_zenoh declares for this entity."""
        parts = [ADMIN_SPACE, str(self.node.domain_id), self.zid, str(self.node_id), str(self.entity_id),
                 self.kind.value, mangle(self.node.enclave), mangle(self.node.namespace), mangle(self.node.name)]
        if self.topic is not None:
            parts += [mangle(self.topic.name), dds_type_name(self.topic.ros_type), self.topic.type_hash,
                      qos_to_keyexpr(self.qos or QoS())]
        return "/".join(parts)

    @property
    def gid(self) -> bytes:
        """The entity's 16-byte GID, derived from its token, so every reader of the token can tell which entity
        sent a sample. (rmw_zenoh takes XXH3-128 of the token; receivers treat the GID as opaque bytes.)"""
        return hashlib.sha256(self.token.encode()).digest()[:GID_SIZE]


_MIN_PARTS, _ALL_PARTS = 9, 13


def parse_token(keyexpr: str) -> Entity:
    """The entity a liveliness token describes, or Ros2WireError naming what does not parse."""
    parts = keyexpr.split("/")
    if len(parts) < _MIN_PARTS:
        raise Ros2WireError(f"token {keyexpr!r} has {len(parts)} parts; at least {_MIN_PARTS} are needed")
    if any(part == "" for part in parts):
        raise Ros2WireError(f"token {keyexpr!r} has an empty part")
    if parts[0] != ADMIN_SPACE:
        raise Ros2WireError(f"token {keyexpr!r} does not start with {ADMIN_SPACE}")
    try:
        kind = EntityKind(parts[5])
    except ValueError:
        raise Ros2WireError(f"token {keyexpr!r}: {parts[5]!r} is no entity kind (NN MP MS SS SC)") from None
    for index, what in ((1, "domain id"), (3, "node id"), (4, "entity id")):
        if not (parts[index].isascii() and parts[index].isdigit()):
            raise Ros2WireError(f"token {keyexpr!r}: {what} {parts[index]!r} is not a number")
    domain_id = int(parts[1])
    node = NodeInfo(domain_id, demangle(parts[7]), demangle(parts[8]), demangle(parts[6]))
    topic, qos = None, None
    if kind is not EntityKind.NODE:
        if len(parts) != _ALL_PARTS:
            raise Ros2WireError(f"token {keyexpr!r} of a {kind.name.lower()} has {len(parts)} parts, not "
                                f"{_ALL_PARTS}")
        topic = TopicKey(domain_id, demangle(parts[9]), ros_type_name(demangle(parts[10])), demangle(parts[11]))
        qos = keyexpr_to_qos(parts[12])
    elif len(parts) != _MIN_PARTS:
        raise Ros2WireError(f"token {keyexpr!r} of a node has {len(parts)} parts, not {_MIN_PARTS}")
    return Entity(parts[2], int(parts[3]), int(parts[4]), kind, node, topic, qos)
