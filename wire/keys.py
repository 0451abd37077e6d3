"""Zenoh key expressions of pitchside: the one place that says how names map to keys.

    <domain>/<robot>/<topic>/<pkg>::msg::dds_::<Type>_/RIHS01_<hash>
                                                   topic data, CDR payload with rmw_zenoh's attachment: the topic
                                                   /<robot>/<topic> of ROS 2 (wire/ros2), domain ROS_DOMAIN_ID
    <domain>/rosout/rcl_interfaces::msg::dds_::Log_/RIHS01_<hash>
                                                   a topic of the root namespace (ROS 2's /rosout): every robot's,
                                                   the robot told by the message (logger name robot1.hcm)
    <domain>/<robot>/<node>/<service>/<pkg>::srv::dds_::<Type>_/RIHS01_<hash>
                                                   a node's parameter services (rcl_interfaces') and the services of
                                                   the table (/<robot>/<service>): rmw_zenoh queryables, CDR with
                                                   attachments (wire.ros2.parameters, wire.services);
                                                   parameter changes on /parameter_events
    <domain>/<robot>/<action>/_action/<part>/...   ROS 2's action protocol for the action /<robot>/<action>:
                                                   services send_goal, cancel_goal, get_result and topics
                                                   feedback, status, in rmw_zenoh's layout (wire/ros2/actions.py)
    @ros2_lv/<domain>/...                          rmw_zenoh's liveliness tokens: the ROS 2 graph (wire/ros2)
    <domain>/<robot>/_doctor/clock                 pitchside doctor's clock probe through the laptop's router
    <domain>/<robot>/_robot_log/list, /file        the robot's own log files, for pitchside logs pull (queries)

Robot ids and topic names come from the network (a Zenoh key, a telemetry header, a log file) and end up in
keys, file names and the dashboard's page: the rules below are checked where they enter, the same everywhere.
"""

from __future__ import annotations

import functools
import re
from typing import Any

import schemas
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


@functools.lru_cache(maxsize=64)
def root_topic_of_key(key: str) -> str | None:
    """The table's topic of the root namespace whose data key this is (``rosout`` for ``/rosout``), None for any
    other key; ValueError for /rosout's name with another type or hash."""
    try:
        return ros2_robots.root_topic(ros2_keys.parse_topic_key(key))
    except ros2_keys.Ros2WireError as exc:
        if "the table's" in str(exc):
            raise ValueError(f"not a pitchside topic key: {key!r} ({exc})") from None
        return None


class NoRobotsMessage(ValueError):
    """A message of a root-namespace topic that is no robot's: /clock (every robot's), a /rosout record of a ROS 2
    node in the root namespace (``talker``)."""


def robot_of_message(topic: str, msg: Any) -> str:
    """The robot a message of a root-namespace topic comes from (/rosout: its logger name ``robot1.hcm``);
    NoRobotsMessage when it names none, ValueError when the robot it names breaks the rules."""
    if topic == "rosout":
        robot = ros2_robots.robot_of_logger(str(getattr(msg, "name", "")))
        if robot is not None:
            return check_robot_id(robot)
    raise NoRobotsMessage(f"a message on /{topic} that names no robot")


def split_sample(key: str, cdr: bytes) -> tuple[str, str]:
    """(robot, topic) of a sample from the bus: from its key, or for a root-namespace topic (/rosout) from the
    message; ValueError for anything else (a name that breaks the rules, a message that does not decode)."""
    topic = root_topic_of_key(key)
    if topic is None:
        return split_topic_key(key)
    if topic == "clock":  # the simulation's time, every robot's: nothing in it says whose
        raise NoRobotsMessage("/clock is every robot's")
    try:
        msg = schemas.decode(cdr, schemas.topic(topic).type)
    except schemas.SchemaError as exc:
        raise ValueError(f"/{topic}: {exc}") from None
    return robot_of_message(topic, msg), topic


def logger_name(robot: str, node: str) -> str:
    """The logger name of a robot's node in its Log records (``robot1.hcm``), as rclcpp names a node's logger."""
    return ros2_robots.logger_name(robot, node)


def is_topic_key(key: str) -> bool:
    """True for a key of rmw_zenoh's data layout (the parameter and service keys are pitchside's); an
    action's feedback and status are hidden topics, as ``ros2 topic list`` hides them."""
    parts = key.rsplit("/", 2)
    return len(parts) == 3 and parts[2].startswith("RIHS01_") and "::msg::dds_::" in parts[1] and \
        "/_action/" not in parts[0]


def robot_log_key(robot: str, part: str) -> str:
    """A robot's log files for ``pitchside logs pull`` (robot_nodes/robot_log/files.py): queries ``list`` and
    ``file`` in the robot's namespace of the domain, so a secured team's access rules let the lab ask and the robot
    answer as they do for its services; a hidden name (``_robot_log``) and no type or hash, so no ROS 2 tool and no
    dashboard takes it for a topic."""
    if part not in ("list", "file"):
        raise ValueError(f"a robot log key is list or file, not {part!r}")
    return f"{domain_id()}/{check_robot_id(robot)}/_robot_log/{part}"


def doctor_probe_key(robot: str) -> str:
    """``pitchside doctor``'s clock probe: a key in the robot's namespace of the domain (its access rules allow it),
    no topic of the table and no rmw_zenoh data key (no type, no hash), so no ROS 2 subscriber and no dashboard
    takes it for data."""
    return f"{domain_id()}/{check_robot_id(robot)}/_doctor/clock"


ACTION_SERVICES = ("send_goal", "cancel_goal", "get_result")


def action_request_keys(robot: str = ANY_ROBOT) -> list[str]:
    """The keys of the services of every action of a robot (of every robot by default): what a client queries,
    so what the lab may send on a secured bus."""
    return [f"{domain_id()}/{robot}/*/_action/{part}/**" for part in ACTION_SERVICES]

