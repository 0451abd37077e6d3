"""/api/state-graphs: a robot's state machine (any StateMachineGraph stream: the HCM's, a behaviour's) laid out by
Graphviz on the server (server.state_graph_layout), for the page's state graph panels to draw."""

from __future__ import annotations

import dataclasses

from fastapi import APIRouter, Depends, HTTPException
from pydantic import BaseModel

from schemas import SchemaError
from server.deps import get_state
from server.state import ServerState
from server.state_graph_layout import StateGraphLayout, layout

router = APIRouter(prefix="/api", tags=["state graphs"])
GRAPH_TYPE = "pitchside_msgs/msg/StateMachineGraph"


class StateBoxModel(BaseModel):
    name: str
    x: float
    y: float
    width: float
    height: float


class TransitionModel(BaseModel):
    from_state: str
    to_state: str
    conditions: list[str]
    path: str  # SVG path data
    head: list[list[float]]  # the arrowhead's base and tip


class StateGraphView(BaseModel):
    robot: str
    topic: str
    machine: str  # the graph's own name ("hcm")
    width: float
    height: float
    font_family: str
    font_size: float
    states: list[StateBoxModel]
    transitions: list[TransitionModel]


@router.get("/state-graphs/{robot}/{topic:path}")
def state_graph(robot: str, topic: str, state: ServerState = Depends(get_state)) -> StateGraphView:
    """The newest graph of the robot's stream, laid out: state boxes and transition splines in points, y down.
    404 before the stream's first message, 422 for a stream of another type or a graph too large to draw, 503
    without Graphviz (server.http_errors)."""
    latest = state.hub.latest.get((robot, topic))
    if latest is None:
        raise HTTPException(404, f"no message on topic {topic!r} from robot {robot!r} yet")
    if latest.typename != GRAPH_TYPE:
        raise HTTPException(422, f"{topic!r} carries {latest.typename}, not {GRAPH_TYPE}")
    try:
        graph = latest.message
    except SchemaError as exc:
        raise HTTPException(422, str(exc)) from None
    drawn: StateGraphLayout = layout(list(graph.states), list(zip(graph.transition_from, graph.transition_to,
                                                                  graph.transition_condition, strict=False)))
    return StateGraphView(robot=robot, topic=topic, machine=graph.name, **dataclasses.asdict(drawn))
