"""GET /api/robots: the robots discovered from what arrived, when each was last heard, link health per stream; the
numeric fields of a stream's newest message."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Depends, HTTPException
from pydantic import BaseModel
from starlette.requests import HTTPConnection

from schemas import SchemaError
from schemas.numeric import numeric_values
from server.deps import get_state, has_credential, require_token
from server.hub import BULK_TYPES
from server.link_health import robots_info
from server.state import ServerState

router = APIRouter(prefix="/api", tags=["robots"])


@router.get("/robots")
def list_robots(state: ServerState = Depends(get_state)) -> list[dict[str, Any]]:
    return robots_info(state)


@router.get("/fields/{robot}/{topic:path}")
def numeric_fields(robot: str, topic: str, state: ServerState = Depends(get_state)) -> dict[str, Any]:
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
    fields = [] if latest.typename in BULK_TYPES else [{"path": f.path, "label": f.label}
                                                        for f in numeric_values(message)]
    return {"robot": robot, "topic": topic, "msgtype": latest.typename, "fields": fields}


@router.get("/hub")
def hub_status(state: ServerState = Depends(get_state)) -> dict[str, Any]:
    """Counters of the hub and of every subscriber (queued, delivered, dropped): where frames go missing."""
    hub = state.hub
    return {
        "published": hub.published,
        "decode_errors": hub.decode_errors,
        "subscribers": [
            {"name": s.name, "queued": len(s), "delivered": s.delivered, "dropped": s.dropped, "thinned": s.thinned,
             "subscriptions": [{"robot": x.robot, "topic": x.topic, "max_hz": x.max_hz} for x in s.subscriptions]}
            for s in hub.subscribers
        ],
    }


@router.get("/robot3d")
def robot3d_status(state: ServerState = Depends(get_state)) -> dict[str, Any]:
    """Which robots the 3D view shows (joint updates applied) and which failed to load, with the reason; how many
    browsers show it; viser's loopback port."""
    view = state.views.get("robot3d")
    return view.status() if view is not None else {"port": None, "viewers": 0, "failed": {}, "robots": {}}


@router.get("/plots")
def plots_status(state: ServerState = Depends(get_state)) -> dict[str, Any]:
    """Whether plots are served, and how many messages the rerun viewer has been fed."""
    plots = state.views.get("plots")
    return plots.status() if plots is not None else {"logged": 0, "robots": []}


class PlotTopic(BaseModel):
    robot: str = "*"
    topic: str
    plotted: bool = True


@router.post("/plots/topics")
def plot_topic(choice: PlotTopic, state: ServerState = Depends(require_token)) -> dict[str, Any]:
    """Plots every numeric field of a topic (of one robot or all) from now on, or stops. Only the server's own
    viewer changes: allowed in match mode, as nothing goes to a robot."""
    plots = state.views.get("plots")
    if plots is None:
        raise HTTPException(404, "plots are off (start the server with --plots)")
    if not choice.topic.strip():
        raise HTTPException(422, "no topic given")
    plots.choose(choice.robot, choice.topic, choice.plotted)
    return dict(plots.status())


@router.get("/config")
def dashboard_config(conn: HTTPConnection, state: ServerState = Depends(get_state)) -> dict[str, Any]:
    """What the page needs to know: match mode, whether this browser may control, the telemetry key in use, where
    the 3D view and plots are (paths on this server: their own servers listen on loopback only)."""
    config = state.config
    return {
        "match_mode": config.match_mode,
        "control": has_credential(conn, state),
        "telemetry_key": state.telemetry_key,
        "stale_after_s": config.stale_after_s,
        "lost_after_s": config.lost_after_s,
        "robot3d": {"view": "robot3d/view/"} if "robot3d" in state.views else None,
        "plots": {"viewer": "plots/viewer/index.html"} if "plots" in state.views else None,
    }
