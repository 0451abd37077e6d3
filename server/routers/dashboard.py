"""/api/config and /api/hub: what the page needs to know of this server, and where the hub's frames go."""

from __future__ import annotations

from fastapi import APIRouter, Depends
from pydantic import BaseModel
from starlette.requests import HTTPConnection

from server.deps import get_state, has_credential
from server.state import ServerState

router = APIRouter(prefix="/api", tags=["dashboard"])


class ViewPath(BaseModel):
    view: str


class ViewerPath(BaseModel):
    viewer: str


class DashboardConfig(BaseModel):
    match_mode: bool
    control: bool  # this browser shows the credential
    telemetry_key: str  # "development" or the team key's fingerprint
    stale_after_s: float
    lost_after_s: float
    robot3d: ViewPath | None  # the 3D view's page on this server, if on
    plots: ViewerPath | None  # the plots viewer's page on this server, if on


class Subscription(BaseModel):
    robot: str
    topic: str
    max_hz: float | None


class SubscriberCounters(BaseModel):
    name: str
    queued: int
    delivered: int
    dropped: int
    thinned: int
    subscriptions: list[Subscription]


class HubCounters(BaseModel):
    published: int
    decode_errors: int
    refused: int  # messages of robots or streams beyond the hub's bounds (server/hub.py MAX_ROBOTS, MAX_STREAMS)
    subscribers: list[SubscriberCounters]


@router.get("/config")
def dashboard_config(conn: HTTPConnection, state: ServerState = Depends(get_state)) -> DashboardConfig:
    """What the page needs to know: match mode, whether this browser may control, the telemetry key in use, where
    the 3D view and plots are (paths on this server: their own servers listen on loopback only)."""
    config = state.config
    return DashboardConfig(
        match_mode=config.match_mode,
        control=has_credential(conn, state),
        telemetry_key=state.telemetry_key,
        stale_after_s=config.stale_after_s,
        lost_after_s=config.lost_after_s,
        robot3d=ViewPath(view="robot3d/view/") if state.robot3d is not None else None,
        plots=ViewerPath(viewer="plots/viewer/index.html") if state.plots is not None else None,
    )


@router.get("/hub")
def hub_status(state: ServerState = Depends(get_state)) -> HubCounters:
    """Counters of the hub and of every subscriber (queued, delivered, dropped): where frames go missing."""
    hub = state.hub
    return HubCounters(
        published=hub.published,
        decode_errors=hub.decode_errors,
        refused=hub.refused,
        subscribers=[
            SubscriberCounters(name=s.name, queued=len(s), delivered=s.delivered, dropped=s.dropped,
                               thinned=s.thinned,
                               subscriptions=[Subscription(robot=x.robot, topic=x.topic, max_hz=x.max_hz)
                                              for x in s.subscriptions])
            for s in hub.subscribers
        ],
    )
