"""From an rmw_zenoh data key to the dashboard's robot, topic and type: the one place that decides it.

- The robot: a domain named in the team file is one robot (its topics are root topics: ``11/joint_states/...`` is
  amy's ``joint_states``); in any other domain a robot is a namespace (``0/robot1/joint_states/...``). A root topic
  there belongs to no robot, except ``/rosout``, whose records name their node (``robot1.hcm``).
- The topic and type: a topic of pitchside's table with the table's type stays as it is; a topic the profile maps
  goes to its panel (translated there); a standard type goes to its panel by type; anything else keeps its own
  name and type, so plots and the topic lists still see it.
- The type must be known (pitchside's, standard, or loaded from the team's interface folder) and its RIHS01 hash
  must be the one in the key; otherwise the topic is refused with the reason, and never decoded.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import schemas
from schemas import codec
from server.profiles.profile import PanelTopic
from server.profiles.team import Ros2Setup
from wire import keys
from wire.ros2.errors import Ros2WireError
from wire.ros2.keys import TopicKey, parse_topic_key

ROSOUT = "rosout"
LOG_TYPE = "rcl_interfaces/msg/Log"


class Refusal(enum.Enum):
    BAD_KEY = "not an rmw_zenoh data key"
    NO_ROBOT = "a root topic of a domain that names no robot (a namespace domain)"
    BAD_NAME = "a robot or topic name the dashboard does not take"
    HIDDEN = "a hidden topic (a name part starting with '_', as an action's feedback; ros2 topic list hides it)"
    DEFINITION_MISSING = "definition missing"
    HASH_MISMATCH = "type hash does not match the type's definition"


class RouteRefused(Exception):
    def __init__(self, reason: Refusal, detail: str, key: TopicKey | None = None) -> None:
        super().__init__(f"{reason.value}: {detail}")
        self.reason = reason
        self.key = key


@dataclass(frozen=True)
class Route:
    """Where one data key's samples go: the hub's robot, topic and type, and how they get there."""

    robot: str  # "" for the global /rosout: taken from each record's node name
    topic: str  # the hub's topic: a panel's, or the robot's own name
    typename: str  # the hub message's type
    wire_type: str  # the type on the bus (what the payload decodes as)
    mapping: PanelTopic | None = None  # translate the team's type into the panel's
    table: bool = False  # a topic of pitchside's table as pitchside's robots publish it (trusted, decoded lazily)


def robot_and_name(key: TopicKey, setup: Ros2Setup) -> tuple[str, str]:
    """(robot, topic name relative to it); RouteRefused where the key names no robot."""
    parts = key.name.strip("/").split("/")
    if key.domain_id in setup.team:
        robot, topic = setup.team[key.domain_id], "/".join(parts)
    elif len(parts) >= 2:
        robot, topic = parts[0], "/".join(parts[1:])
    elif parts == [ROSOUT] and key.ros_type == LOG_TYPE:
        robot, topic = "", ROSOUT
    else:
        raise RouteRefused(Refusal.NO_ROBOT, key.name, key)
    if any(part.startswith("_") for part in parts):
        raise RouteRefused(Refusal.HIDDEN, key.name, key)
    if (robot and not keys.is_valid_name(robot)) or not keys.is_valid_topic(topic):
        raise RouteRefused(Refusal.BAD_NAME, f"{robot!r} {topic!r} ({keys.NAME_RULE}; {keys.TOPIC_RULE})", key)
    return robot, topic


def check_type(key: TopicKey) -> None:
    """RouteRefused unless the key's type is known and its hash is the one pitchside computes from it."""
    try:
        expected = codec.type_hash(key.ros_type)
    except schemas.SchemaError:
        raise RouteRefused(Refusal.DEFINITION_MISSING, key.ros_type, key) from None
    if expected != key.type_hash:
        raise RouteRefused(Refusal.HASH_MISMATCH, f"{key.name} says {key.type_hash} for {key.ros_type}, its "
                           f"definition hashes to {expected}", key)


def route(keyexpr: str, setup: Ros2Setup) -> Route:
    """The route of a data key; RouteRefused (with the reason) for a key the dashboard cannot show."""
    try:
        key = parse_topic_key(keyexpr)
    except Ros2WireError as exc:
        raise RouteRefused(Refusal.BAD_KEY, str(exc)) from None
    robot, topic = robot_and_name(key, setup)
    check_type(key)
    entry = schemas.TOPICS.get(topic)
    if entry is not None and entry.type == key.ros_type:
        return Route(robot, topic, entry.type, key.ros_type, table=key.domain_id not in setup.team)
    panel = setup.profile.panel_of(topic, key.ros_type)
    if panel is not None:
        panel_topic, mapping = panel
        return Route(robot, panel_topic, schemas.topic(panel_topic).type, key.ros_type, mapping)
    return Route(robot, topic, key.ros_type, key.ros_type)
