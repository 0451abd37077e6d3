"""/api/foxglove: the Foxglove endpoint's state (where it listens, who connected, who was refused and why) and the
Foxglove/Lichtblick layout pitchside ships (server.foxglove_layout), to import in the app.

Reading only, behind the same Host, Origin and credential checks as every other /api/ path (beyond loopback they need
the token). ``/api/foxglove/layout?robot=`` makes the layout another robot's; it downloads as
``pitchside-<robot>.json``.
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Depends
from fastapi.responses import Response

from server.deps import get_state, valid_robot
from server.foxglove_layout import LAYOUT_ROBOT, layout_text
from server.state import ServerState

router = APIRouter(prefix="/api/foxglove", tags=["foxglove"])


@router.get("")
def foxglove_status(state: ServerState = Depends(get_state)) -> dict[str, Any]:
    """The endpoint's figures (server.foxglove.endpoint.FoxgloveEndpoint.status); ``running`` false when it is off."""
    if state.foxglove is None:
        return {"running": False}
    return {"running": True, **state.foxglove.status()}


def layout_robot(robot: str = LAYOUT_ROBOT) -> str:
    return valid_robot(robot)


# the answer is the layout file itself (Foxglove's and Lichtblick's LayoutData), sent as it is written
LAYOUT_ANSWER: dict[int | str, dict[str, Any]] = {200: {"content": {"application/json": {"schema": {
    "type": "object", "description": "a Foxglove/Lichtblick layout (configById, layout, globalVariables, ...)"}}}}}


@router.get("/layout", responses=LAYOUT_ANSWER)
def foxglove_layout(robot: str = Depends(layout_robot)) -> Response:
    """The shipped layout for ``robot``, as a file to import in Foxglove or Lichtblick."""
    return Response(layout_text(robot), media_type="application/json",
                    headers={"Content-Disposition": f'attachment; filename="pitchside-{robot}.json"'})
