"""Zenoh key expressions of pitchside: the one place that says how names map to keys.

    <domain>/<robot>/<topic>/<pkg>::msg::dds_::<Type>_/RIHS01_<hash>
                                                   topic data, CDR payload with rmw_zenoh's attachment: the topic
                                                   /<robot>/<topic> of ROS 2 (wire/ros2), domain ROS_DOMAIN_ID
    <domain>/<robot>/<node>/<service>/<pkg>::srv::dds_::<Type>_/RIHS01_<hash>
                                                   a node's parameter services (rcl_interfaces') and the services of
                                                   the table (/<robot>/<service>): rmw_zenoh queryables, CDR with
                                                   attachments (wire.ros2.parameters, wire.services);
                                                   parameter changes on /parameter_events
    pitchside/<robot>/_action/<action>/goal        queryable: 16-byte goal id + CDR goal -> JSON verdict
    pitchside/<robot>/_action/<action>/cancel      queryable: 16-byte goal id -> JSON verdict
    pitchside/<robot>/_action/<action>/events      16-byte goal id + b"F" + CDR feedback, or
                                                   16-byte goal id + b"R" + 1 status byte + CDR result
                                                   (one key, so a result never overtakes its last feedback)
    pitchside/<robot>/_graph/<node>/<role>/<name>  Zenoh liveliness token while the node has it (the node graph):
                                                   role pub/sub (the robot's own topic), suball (the topic of
                                                   every robot), srv (a service it serves), action (an action it
                                                   serves); name a topic, service or action name

Robot ids and topic names come from the network (a Zenoh key, a telemetry header, a log file) and end up in
keys, file names and the dashboard's page: the rules below are checked where they enter, the same everywhere.
"""

from __future__ import annotations

import functools
import re

from wire.ros2 import keys as ros2_keys
from wire.ros2 import robots as ros2_robots

PREFIX = "pitchside"
ANY_ROBOT = "*"

# a robot id fits the telemetry header's 12 bytes and needs no escaping anywhere (key, file name, HTML)
_ROBOT_ID = re.compile(r"^[A-Za-z0-9_-]{1,12}$")
NAME_RULE = "1-12 characters of A-Z a-z 0-9 _ -"
# a topic: ROS 2 name tokens (letters, digits, '_') joined by '/', a leading '/' allowed (ROS 2 bags)
_TOPIC = re.compile(r"^/?[A-Za-z0-9_]+(?:/[A-Za-z0-9_]+)*$")
TOPIC_RULE = "letters, digits and '_' in parts joined by '/', at most 200 characters"
MAX_TOPIC = 200
# a node's name: one part of a parameter key and of the dashboard's URLs (ROS 2 node names are such tokens)
_NODE = re.compile(r"^[A-Za-z0-9_]{1,64}$")
NODE_RULE = "1-64 letters, digits or '_'"


def is_valid_name(robot: str) -> bool:
    """True for a robot id as every part of pitchside takes it."""
    return bool(_ROBOT_ID.match(robot))


# A replayed robot is a robot of its own in the server's hub and the page: "replay." + its id in the log. The '.'
# is one no live id may have, so a replayed robot never merges with (or is commanded as) a live one of that id.
REPLAY_NAMESPACE = "replay."
UNNAMED_IN_LOG = "log"  # the robot of a log's channels that name none (a ROS 2 bag's /rosout)


def replayed_robot_id(robot: str) -> str:
    """The hub's id of a robot seen in a replayed log ("" for channels that name no robot)."""
    return REPLAY_NAMESPACE + (robot or UNNAMED_IN_LOG)


def is_replayed(robot: str) -> bool:
    """True for a hub robot id that a replay made (replayed_robot_id)."""
    return robot.startswith(REPLAY_NAMESPACE)


def robot_in_log(robot: str) -> str:
    """The id a replayed robot has in its log (and in the log's messages, e.g. ground truth's robot_ids)."""
    return robot[len(REPLAY_NAMESPACE):] if is_replayed(robot) else robot


def check_robot_id(robot: str) -> str:
    """The robot id, or ValueError saying the rule."""
    if not isinstance(robot, str) or not is_valid_name(robot):
        raise ValueError(f"robot id {robot!r} must be {NAME_RULE}")
    return robot


def is_valid_node_name(node: str) -> bool:
    """True for a node name as it may stand in a parameter key (a node's answer naming another is not believed)."""
    return bool(_NODE.match(node))


def is_valid_topic(topic: str) -> bool:
    return len(topic) <= MAX_TOPIC and bool(_TOPIC.match(topic))


def check_topic(topic: str) -> str:
    if not isinstance(topic, str) or not is_valid_topic(topic):
        raise ValueError(f"topic {topic!r} must be {TOPIC_RULE}")
    return topic


def domain_id() -> int:
    """The ROS 2 domain pitchside's topics are in (ROS_DOMAIN_ID, 0 when unset)."""
    return ros2_keys.domain_id_from_env()


def topic_key(robot: str, topic: str) -> str:
    """The data key of a topic of the table on a robot: rmw_zenoh's key of the ROS 2 topic /<robot>/<topic>.
    ``robot`` may be ANY_ROBOT ("*"), ``topic`` "**" (every topic of the robot, for subscriptions and ACLs)."""
    if topic == "**":
        return f"{domain_id()}/{robot}/**"
    if robot == ANY_ROBOT:
        key = ros2_robots.topic_key("any", topic, domain_id())
        return key.keyexpr.replace(f"{key.domain_id}/any/", f"{key.domain_id}/{ANY_ROBOT}/", 1)
    return ros2_robots.topic_key(robot, topic, domain_id()).keyexpr


def graph_tokens_key() -> str:
    """Every liveliness token of the domain's ROS 2 graph (rmw_zenoh's ``@ros2_lv/<domain>/**``)."""
    return f"@ros2_lv/{domain_id()}/**"


def all_topics_key() -> str:
    """Every topic of every robot of the domain (the live source's subscription)."""
    return topic_key(ANY_ROBOT, "**")


@functools.lru_cache(maxsize=4096)
def split_topic_key(key: str) -> tuple[str, str]:
    """(robot, topic) of a topic key; ValueError for other keys and for a robot id or topic that breaks the rules
    (cached: a bus has few keys and the dashboard asks for every sample)."""
    try:
        robot, topic = ros2_robots.robot_and_topic(ros2_keys.parse_topic_key(key))
    except (ros2_keys.Ros2WireError, KeyError) as exc:
        raise ValueError(f"not a pitchside topic key: {key!r} ({exc})") from None
    return check_robot_id(robot), check_topic(topic)


def is_topic_key(key: str) -> bool:
    """True for a topic key of rmw_zenoh's data layout (not a service's, nor pitchside's action and graph keys)."""
    parts = key.rsplit("/", 2)
    return len(parts) == 3 and parts[2].startswith("RIHS01_") and "::msg::dds_::" in parts[1]


def action_key(robot: str, action: str, part: str) -> str:
    if part not in ("goal", "cancel", "events"):
        raise ValueError(f"unknown action key part {part!r}")
    return f"{PREFIX}/{robot}/_action/{action}/{part}"


# The node graph (robot_nodes/runtime/graph.py announces, the server's node graph reads): a liveliness token per thing
# a node publishes, subscribes or serves, gone with the node (or its process, or its link).
GRAPH_ROLES = ("pub", "sub", "suball", "srv", "action")
GRAPH_ALL = f"{PREFIX}/*/_graph/**"


def graph_key(robot: str, node: str, role: str, name: str) -> str:
    """The liveliness key of one entry of a node's graph; ValueError for a name that breaks the rules."""
    if role not in GRAPH_ROLES:
        raise ValueError(f"graph role {role!r} is not one of {GRAPH_ROLES}")
    if not is_valid_name(robot) or not is_valid_node_name(node) or not is_valid_topic(name) or name.startswith("/"):
        raise ValueError(f"graph entry {robot!r}/{node!r}/{name!r} breaks the naming rules")
    return f"{PREFIX}/{robot}/_graph/{node}/{role}/{name}"


def split_graph_key(key: str) -> tuple[str, str, str, str]:
    """(robot, node, role, name) of a graph key; ValueError for anything else (names are checked by the rules)."""
    parts = key.split("/", 5)
    if len(parts) != 6 or parts[0] != PREFIX or parts[2] != "_graph" or parts[4] not in GRAPH_ROLES:
        raise ValueError(f"not a node graph key: {key!r}")
    robot, node, role, name = parts[1], parts[3], parts[4], parts[5]
    if not is_valid_name(robot) or not is_valid_node_name(node) or not is_valid_topic(name) or name.startswith("/"):
        raise ValueError(f"node graph key {key!r} breaks the naming rules")
    return robot, node, role, name
