"""Teleop (lab only): a held walk command for one robot, sent as cmd_vel at 10 Hz until released or stale.

The browser refreshes the command while a key or the joystick is held (every ~100-200 ms); if the refreshes
stop (released, tab closed, network gone), the server sends zero after ``hold_s``. Refused in match mode.
"""

from __future__ import annotations

from fastapi import APIRouter, Depends
from pydantic import BaseModel

from server.deps import require_control, robot_on_link, valid_robot
from server.drive_command import DriveCommand
from server.lab import TELEOP_HZ, lab_tools
from server.state import ServerState

router = APIRouter(prefix="/api/robots/{robot}/teleop", tags=["teleop"], dependencies=[Depends(valid_robot)])


class Driving(BaseModel):
    robot: str
    x: float
    y: float
    yaw: float
    rate_hz: float  # cmd_vel is sent this often while held
    sent: int  # cmd_vel messages sent for this hold so far


class Halted(BaseModel):
    robot: str
    x: float
    y: float
    yaw: float


@router.post("", dependencies=[Depends(robot_on_link)])
async def drive(robot: str, command: DriveCommand, state: ServerState = Depends(require_control)) -> Driving:
    cmd = await lab_tools(state).drive(robot, command.x, command.y, command.yaw, command.hold_s)
    return Driving(robot=robot, x=cmd.x, y=cmd.y, yaw=cmd.yaw, rate_hz=TELEOP_HZ, sent=cmd.sent)


@router.post("/stop")
async def stop(robot: str, state: ServerState = Depends(require_control)) -> Halted:
    """Zero at once (also when nothing was being sent)."""
    await lab_tools(state).halt(robot)
    return Halted(robot=robot, x=0.0, y=0.0, yaw=0.0)
