"""pitchside's robots and topic table on rmw_zenoh's wire: a robot is a ROS 2 namespace (``/robot1``), a topic of
the table is a name in it (``/robot1/joint_states``) with the table's type and the type's RIHS01 hash.

The one place that turns (robot, topic) into a ROS 2 data key and back, for the runtime and the dashboard.
"""

from __future__ import annotations

import itertools
import re

import schemas
from schemas.codec import type_hash
from wire.ros2.errors import Ros2WireError
from wire.ros2.keys import DEFAULT_DOMAIN_ID, TopicKey
from wire.ros2.liveliness import Entity, EntityKind, NodeInfo
from wire.ros2.qos import ROSOUT, Durability, QoS

# a namespace token of ROS 2: letters, digits and '_', not starting with a digit (pitchside's robot ids also allow
# '-' and a leading digit, which ROS 2 names cannot carry)
_ROS2_TOKEN = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def robot_namespace(robot: str) -> str:
    """``robot1`` -> ``/robot1``; Ros2WireError for an id that is no ROS 2 namespace."""
    if not _ROS2_TOKEN.match(robot):
        raise Ros2WireError(f"robot id {robot!r} is no ROS 2 namespace: letters, digits and '_', "
                            "not starting with a digit")
    return "/" + robot


def topic_name(robot: str, topic: str) -> str:
    """The ROS 2 name of a topic of the table on a robot: ``/robot1/joint_states``, or ``/rosout`` for a topic of
    the root namespace (every robot's, the robot told by the message)."""
    entry = schemas.topic(topic)
    return f"/{topic}" if entry.root else f"{robot_namespace(robot)}/{topic}"


def topic_key(robot: str, topic: str, domain_id: int = DEFAULT_DOMAIN_ID) -> TopicKey:
    """The data key of a topic of the table on a robot."""
    entry = schemas.topic(topic)
    return TopicKey(domain_id, topic_name(robot, topic), entry.type, type_hash(entry.type))


def topic_qos(topic: str) -> QoS:
    """The QoS a pitchside node publishes and subscribes a topic of the table with, as rclcpp's defaults and rcl's
    /rosout have it: reliable, KEEP_LAST 10, volatile; latched topics transient local with their depth, /rosout
    as rcl's (depth 1000, a lifespan of 10 s)."""
    entry = schemas.topic(topic)
    if entry.name == "rosout":
        return ROSOUT
    if entry.latched:
        return QoS(durability=Durability.TRANSIENT_LOCAL, depth=entry.latched)
    return QoS(depth=10)


def root_topic(key: TopicKey) -> str | None:
    """The table's topic of the root namespace a data key is of (``rosout``), None for any other key; Ros2WireError
    when its type or hash is not the table's."""
    name = key.name.strip("/")
    entry = schemas.TOPICS.get(name)
    if entry is None or not entry.root:
        return None
    if key.ros_type != entry.type or key.type_hash != type_hash(entry.type):
        raise Ros2WireError(f"{key.name!r} carries {key.ros_type} {key.type_hash}; the table's {name} is "
                            f"{entry.type} {type_hash(entry.type)}")
    return name


def logger_name(robot: str, node: str) -> str:
    """The logger name a node's Log records carry on /rosout, as rclcpp and rclpy name a node's logger: its
    namespace and name joined by '.' (``robot1.hcm``)."""
    return f"{robot_namespace(robot)[1:]}.{node}"


def robot_of_logger(name: str) -> str | None:
    """The robot of a Log's logger name (``robot1.hcm`` -> ``robot1``; a child logger ``robot1.hcm.walk`` too);
    None for a name in the root namespace (``talker``), which names no robot."""
    robot, dot, _ = name.partition(".")
    return robot if dot and _ROS2_TOKEN.match(robot) else None


def service_key(robot: str, service: str, domain_id: int = DEFAULT_DOMAIN_ID) -> TopicKey:
    """The data key of a service of the table (a queryable in rmw_zenoh) on a robot."""
    if service not in schemas.SERVICES:
        raise KeyError(f"service {service!r} is not in the table (schemas/topics.py)")
    srv_type = schemas.SERVICES[service].type
    return TopicKey(domain_id, f"{robot_namespace(robot)}/{service}", srv_type, type_hash(srv_type))


def robot_and_topic(key: TopicKey) -> tuple[str, str]:
    """(robot, topic) of a data key a pitchside robot's node publishes; Ros2WireError for any other key (a root
    namespace topic, a name or type that is not the table's)."""
    parts = key.name.strip("/").split("/", 1)
    if len(parts) != 2:
        raise Ros2WireError(f"{key.name!r} is not in a robot's namespace")
    robot, topic = parts
    entry = schemas.TOPICS.get(topic)
    if entry is None:
        raise Ros2WireError(f"{key.name!r}: {topic!r} is not a topic of the table")
    if key.ros_type != entry.type or key.type_hash != type_hash(entry.type):
        raise Ros2WireError(f"{key.name!r} carries {key.ros_type} {key.type_hash}; the table's {topic} is "
                            f"{entry.type} {type_hash(entry.type)}")
    return robot, topic


_NODE_IDS = itertools.count()


def next_node_id() -> int:
    """A node id unique in this process (rmw_zenoh numbers the nodes of a context)."""
    return next(_NODE_IDS)


def node_entity(zid: str, robot: str, node: str, node_id: int, domain_id: int = DEFAULT_DOMAIN_ID) -> Entity:
    """The rmw_zenoh entity of a robot's node: ``ros2 node list`` shows it as /<robot>/<node>."""
    return Entity(zid, node_id, node_id, EntityKind.NODE, NodeInfo(domain_id, robot_namespace(robot), node))


def publisher_entity(zid: str, robot: str, node: str, topic: str, node_id: int, entity_id: int,
                     domain_id: int = DEFAULT_DOMAIN_ID, qos: QoS | None = None) -> Entity:
    """The rmw_zenoh entity of a node's publisher of a topic of the table: its token, and the GID its samples
    carry."""
    return _topic_entity(EntityKind.PUBLISHER, zid, robot, node, topic, node_id, entity_id, domain_id, qos)


def subscription_entity(zid: str, robot: str, node: str, topic: str, node_id: int, entity_id: int,
                        domain_id: int = DEFAULT_DOMAIN_ID, qos: QoS | None = None,
                        topic_robot: str | None = None) -> Entity:
    """The rmw_zenoh entity of a node's subscription to a topic of the table, of its own robot or of
    ``topic_robot`` (a teammate's)."""
    # volatile, whatever the topic: the runtime's subscriptions take what comes, they ask no publisher's cache
    return _topic_entity(EntityKind.SUBSCRIPTION, zid, robot, node, topic, node_id, entity_id, domain_id,
                         qos or QoS(depth=10),
                         topic_robot)


def _topic_entity(kind: EntityKind, zid: str, robot: str, node: str, topic: str, node_id: int, entity_id: int,
                  domain_id: int, qos: QoS | None, topic_robot: str | None = None) -> Entity:
    return Entity(zid, node_id, entity_id, kind, NodeInfo(domain_id, robot_namespace(robot), node),
                  topic_key(topic_robot or robot, topic, domain_id), qos or topic_qos(topic))
