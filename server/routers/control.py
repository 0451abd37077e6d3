"""The control API (lab only): parameters, penalize, play animation. Refused in match mode; token off loopback.

Everything here talks to robots over Zenoh (the server's ZenohLink), so every endpoint depends on
``require_control``: 403 with the reason in match mode, 401 without the token when listening beyond loopback.
"""

from __future__ import annotations

import asyncio
from typing import Any, Literal

from fastapi import APIRouter, Depends, HTTPException
from pydantic import BaseModel

import schemas
from server.deps import require_control, robot_on_link, valid_node, valid_robot
from server.state import ServerState
from wire.actions import ActionClient, ActionError
from wire.parameters import ParameterClient, ParameterError
from wire.services import ServiceError, call_service

router = APIRouter(prefix="/api/robots/{robot}", tags=["control"], dependencies=[Depends(valid_robot)])
TIMEOUT_S = 3.0


class ParameterWrite(BaseModel):
    values: dict[str, Any]
    revisions: dict[str, int] | None = None


class PenalizeRequest(BaseModel):
    penalize: Literal["on", "off", "switch"] = "on"


class AnimationRequest(BaseModel):
    animation: str
    wait: bool = False  # wait for the result (else answer once the HCM accepted or rejected the goal)


def _parameter_client(state: ServerState, robot: str) -> ParameterClient:
    return ParameterClient(state.link.session(), robot, timeout=TIMEOUT_S)


@router.get("/params", dependencies=[Depends(robot_on_link)])
async def list_parameters(robot: str, state: ServerState = Depends(require_control)) -> dict[str, Any]:
    """Every node of the robot that answers, with its parameters."""
    return await asyncio.to_thread(lambda: _parameter_client(state, robot).nodes())


@router.get("/params/{node}", dependencies=[Depends(robot_on_link), Depends(valid_node)])
async def get_parameters(robot: str, node: str, state: ServerState = Depends(require_control)
                         ) -> list[dict[str, Any]]:
    try:
        return await asyncio.to_thread(lambda: _parameter_client(state, robot).describe(node))
    except ParameterError as exc:
        raise HTTPException(504, str(exc)) from exc


@router.post("/params/{node}", dependencies=[Depends(robot_on_link), Depends(valid_node)])
async def set_parameters(robot: str, node: str, write: ParameterWrite, state: ServerState = Depends(require_control)
                         ) -> dict[str, Any]:
    """The node validates: out of range -> 422 with its reason, value unchanged; a write based on an old revision
    (someone else changed the value meanwhile) -> 409."""
    try:
        return await asyncio.to_thread(lambda: _parameter_client(state, robot).set(node, write.values,
                                                                                    write.revisions))
    except ParameterError as exc:
        raise HTTPException(409 if "changed meanwhile" in str(exc) else 422, str(exc)) from exc


@router.post("/penalize", dependencies=[Depends(robot_on_link)])
async def penalize(robot: str, request: PenalizeRequest, state: ServerState = Depends(require_control)
                   ) -> dict[str, Any]:
    consts = schemas.constants("humanoid_league_msgs/srv/ManualPenalize_Request")
    msg = schemas.make("humanoid_league_msgs/srv/ManualPenalize_Request", penalize=consts[request.penalize.upper()])
    try:
        response = await asyncio.to_thread(
            lambda: call_service(state.link.session(), robot, "manual_penalize", msg, timeout=TIMEOUT_S))
    except ServiceError as exc:
        raise HTTPException(504, str(exc)) from exc
    return {"robot": robot, "penalized": bool(response.penalized)}


@router.post("/animation", dependencies=[Depends(robot_on_link)])
async def play_animation(robot: str, request: AnimationRequest, state: ServerState = Depends(require_control)
                         ) -> dict[str, Any]:
    goal = schemas.make("humanoid_league_msgs/action/PlayAnimation_Goal", animation=request.animation, hcm=False)

    def send() -> dict[str, Any]:
        client = ActionClient(state.link.session(), robot, "animation")
        try:
            handle = client.send_goal(goal, timeout=TIMEOUT_S)
            if not handle.wait_accepted(TIMEOUT_S):
                raise HTTPException(409, f"animation {request.animation!r} rejected: {handle.reason}")
            if not request.wait:
                return {"robot": robot, "animation": request.animation, "accepted": True}
            status, result = handle.wait_result(60.0)
            return {"robot": robot, "animation": request.animation, "accepted": True, "status": status.name,
                    "result": schemas.to_dict(result)}
        finally:
            client.close()

    try:
        return await asyncio.to_thread(send)
    except ActionError as exc:
        raise HTTPException(504, str(exc)) from exc
