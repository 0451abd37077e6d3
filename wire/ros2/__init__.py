"""rmw_zenoh's wire (rmw_zenoh_cpp 0.2.x of Jazzy; Kilted and Rolling speak the same): data keys, liveliness
tokens with their QoS, and the attachment, so pitchside and ROS 2 nodes share one Zenoh bus with no bridge.

keys, liveliness, qos and attachment are pure formatting and parsing; graph (discovery from liveliness tokens) and
endpoints (a node's tokens, publishers and subscriptions) put them on a Zenoh session.
"""

from wire.ros2.attachment import Attachment, decode_attachment
from wire.ros2.errors import Ros2WireError
from wire.ros2.keys import (
    DEFAULT_DOMAIN_ID,
    TopicKey,
    dds_type_name,
    domain_id_from_env,
    fully_qualified_name,
    parse_topic_key,
    ros_type_name,
)
from wire.ros2.liveliness import Entity, EntityKind, NodeInfo, demangle, mangle, parse_token, subscription_keyexpr
from wire.ros2.qos import QoS, keyexpr_to_qos, qos_to_keyexpr

__all__ = [
    "DEFAULT_DOMAIN_ID",
    "Attachment",
    "Entity",
    "EntityKind",
    "NodeInfo",
    "QoS",
    "Ros2WireError",
    "TopicKey",
    "dds_type_name",
    "decode_attachment",
    "demangle",
    "domain_id_from_env",
    "fully_qualified_name",
    "keyexpr_to_qos",
    "mangle",
    "parse_token",
    "parse_topic_key",
    "qos_to_keyexpr",
    "ros_type_name",
    "subscription_keyexpr",
]
