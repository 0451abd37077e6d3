"""Zenoh key expressions of pitchside: the one place that says how names map to keys.

    pitchside/<robot>/<topic>                      topic data, CDR payload
    pitchside/<robot>/params/<node>                parameter queryable, JSON request/reply
    pitchside/<robot>/params/<node>/changed        JSON event after every accepted change
    pitchside/<robot>/_srv/<service>               service queryable, CDR request/reply
    pitchside/<robot>/_action/<action>/goal        queryable: 16-byte goal id + CDR goal -> JSON verdict
    pitchside/<robot>/_action/<action>/cancel      queryable: 16-byte goal id -> JSON verdict
    pitchside/<robot>/_action/<action>/events      16-byte goal id + b"F" + CDR feedback, or
                                                   16-byte goal id + b"R" + 1 status byte + CDR result
                                                   (one key, so a result never overtakes its last feedback)
"""

from __future__ import annotations

PREFIX = "pitchside"
ANY_ROBOT = "*"


def topic_key(robot: str, topic: str) -> str:
    return f"{PREFIX}/{robot}/{topic}"


def split_topic_key(key: str) -> tuple[str, str]:
    """(robot, topic) of a topic key; ValueError for other keys."""
    parts = key.split("/", 2)
    if len(parts) != 3 or parts[0] != PREFIX:
        raise ValueError(f"not a pitchside topic key: {key!r}")
    return parts[1], parts[2]


def is_topic_key(key: str) -> bool:
    """False for the parameter, service and action keys that share the robot's prefix."""
    parts = key.split("/", 3)
    return len(parts) >= 3 and parts[0] == PREFIX and parts[2] not in ("params", "_srv", "_action")


def params_key(robot: str, node: str) -> str:
    return f"{PREFIX}/{robot}/params/{node}"


def params_changed_key(robot: str, node: str) -> str:
    return f"{PREFIX}/{robot}/params/{node}/changed"


def service_key(robot: str, service: str) -> str:
    return f"{PREFIX}/{robot}/_srv/{service}"


def action_key(robot: str, action: str, part: str) -> str:
    if part not in ("goal", "cancel", "events"):
        raise ValueError(f"unknown action key part {part!r}")
    return f"{PREFIX}/{robot}/_action/{action}/{part}"
