"""/api/robots: the robots discovered from what arrived, when each was last heard, link health per stream; the
numeric fields of a stream's newest message; and penalizing a robot (lab only: a service call to its HCM)."""

from __future__ import annotations

import asyncio
from typing import Any, Literal

from fastapi import APIRouter, Depends, HTTPException
from pydantic import BaseModel, ConfigDict

from schemas import SchemaError
from schemas.messages import ManualPenalizeRequest
from schemas.numeric import numeric_values
from server.deps import get_state, require_control, robot_on_link, valid_robot
from server.hub import BULK_TYPES
from server.link_health import robots_info
from server.state import ServerState
from wire.services import call_service

router = APIRouter(prefix="/api", tags=["robots"])
TIMEOUT_S = 3.0


class StreamHealth(BaseModel):
    """One stream of a robot as the server hears it; a source may add its own link figures (telemetry: loss_pct,
    budget_share, link_rate_hz)."""

    model_config = ConfigDict(extra="allow")
    msgtype: str
    source: str
    count: int
    rate_hz: float
    age_s: float
    late: int | None = None  # arrived late after a link cut: recorded, never shown as live


class RobotHealth(BaseModel):
    robot: str
    first_seen: float
    age_s: float
    status: Literal["ok", "stale", "lost"]
    streams: dict[str, StreamHealth]
    replayed: bool = False  # a robot of the open replay (wire.keys.replayed_robot_id), not a live one
    log_robot: str | None = None  # a replayed robot's id in the log (and in its messages' robot lists)


class NumericField(BaseModel):
    path: str  # where the number is in the message's JSON view
    label: str  # array elements named after the message's own name list
    name: str  # the path with array elements by name where they have one ("position/RKnee"): a joint's name


class NumericFields(BaseModel):
    robot: str
    topic: str
    msgtype: str
    fields: list[NumericField]


class PenalizeRequest(BaseModel):
    penalize: Literal["on", "off", "switch"] = "on"


class Penalized(BaseModel):
    robot: str
    penalized: bool


@router.get("/robots", response_model=list[RobotHealth], response_model_exclude_unset=True)
def list_robots(state: ServerState = Depends(get_state)) -> list[dict[str, Any]]:
    return robots_info(state)


@router.get("/fields/{robot}/{topic:path}")
def numeric_fields(robot: str, topic: str, state: ServerState = Depends(get_state)) -> NumericFields:
    """The numeric fields of the newest message of one robot's stream, as schemas.numeric defines them: what the
    field choosers of the parameters and replay panels offer. ``path`` addresses the number in the message's JSON
    view (a msg frame's data); ``label`` names array elements after the message's own name list."""
    latest = state.hub.latest.get((robot, topic))
    if latest is None:
        raise HTTPException(404, f"no message on topic {topic!r} from robot {robot!r} yet")
    try:
        message = latest.message
    except SchemaError as exc:
        raise HTTPException(422, str(exc)) from None
    fields = [] if latest.typename in BULK_TYPES else [NumericField(path=f.path, label=f.label, name=f.name)
                                                        for f in numeric_values(message)]
    return NumericFields(robot=robot, topic=topic, msgtype=latest.typename, fields=fields)


@router.post("/robots/{robot}/penalize", dependencies=[Depends(valid_robot), Depends(robot_on_link)])
async def penalize(robot: str, request: PenalizeRequest, state: ServerState = Depends(require_control)) -> Penalized:
    """The HCM's manual_penalize service; a robot that does not answer: 504 (server.http_errors)."""
    msg = ManualPenalizeRequest(penalize=getattr(ManualPenalizeRequest, request.penalize.upper()))
    response = await asyncio.to_thread(
        lambda: call_service(state.link.session(), robot, "manual_penalize", msg, timeout=TIMEOUT_S))
    return Penalized(robot=robot, penalized=bool(response.penalized))
