"""A held walk command's limits, one definition for both ways in: the HTTP teleop router and a Foxglove client's
cmd_vel (server/foxglove/teleop.py). Kept below both adapters, so neither imports the other."""

from __future__ import annotations

from pydantic import BaseModel, Field

from server.lab import TELEOP_HOLD_S


class DriveCommand(BaseModel):
    x: float = Field(0.0, ge=-1.0, le=1.0, description="forward, m/s")
    y: float = Field(0.0, ge=-1.0, le=1.0, description="left, m/s")
    yaw: float = Field(0.0, ge=-3.0, le=3.0, description="turn left, rad/s")
    hold_s: float = Field(TELEOP_HOLD_S, gt=0.0, le=2.0, description="zero after this long without a refresh")
