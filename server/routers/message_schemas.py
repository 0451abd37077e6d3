"""GET /api/schemas: what the page knows of the messages, from the schemas themselves (the .msg files and the topic
table), so the browser keeps no copy: the constants of every type the topics carry, and the topic table."""

from __future__ import annotations

import functools
from typing import Any

from fastapi import APIRouter
from pydantic import BaseModel

from schemas import TOPICS, constants
from schemas.codec import typestore

router = APIRouter(prefix="/api", tags=["schemas"])


class TopicInfo(BaseModel):
    type: str  # the message type, e.g. sensor_msgs/msg/JointState
    description: str
    priority: str  # the telemetry priority's name
    event: bool  # sent on change rather than at a rate


class SchemaInfo(BaseModel):
    topics: dict[str, TopicInfo]
    constants: dict[str, dict[str, Any]]  # per message type: constant name -> value, as the .msg file says


def carried_types() -> list[str]:
    """Every message type the topic table's topics carry, the types nested in them included."""
    fielddefs: dict[str, Any] = typestore().fielddefs
    seen: set[str] = set()
    todo = [t.type for t in TOPICS.values()]
    while todo:
        typename = todo.pop()
        if typename in seen:
            continue
        seen.add(typename)
        field: Any
        for _, field in fielddefs[typename][1]:
            kind, detail = field
            # rosbags field kinds: 1 base, 2 nested message, 3 array, 4 sequence (of (kind, detail))
            if kind in (3, 4):
                kind, detail = detail[0]
            if kind == 2:
                todo.append(detail)
    return sorted(seen)


@functools.cache
def schema_info() -> dict[str, Any]:
    """{"topics": {name: {type, description, priority, event}}, "constants": {type: {NAME: value}}}."""
    return {
        "topics": {t.name: {"type": t.type, "description": t.description, "priority": t.priority.name,
                            "event": t.event} for t in TOPICS.values()},
        "constants": {typename: consts for typename in carried_types() if (consts := constants(typename))},
    }


@router.get("/schemas", response_model=SchemaInfo)
def message_schemas() -> dict[str, Any]:
    """The topic table and the constants of the messages its topics carry (state names, colours, levels)."""
    return schema_info()
