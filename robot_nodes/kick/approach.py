"""Kick geometry: which foot, where the robot must stand for it, and the walk command that takes it there.

Everything is in the walking's odometry frame (walk_odometry), which stays put while the robot walks, so the ball's
sightings from different moments can be averaged and the kick direction does not turn with the robot.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from robot_nodes.ground_pose import GroundPose, wrap


@dataclass(frozen=True)
class KickSpot:
    """Where the ball's centre must be, relative to base_footprint, for a kick with the left foot (the right one is
    mirrored), and how close is close enough."""

    x: float = 0.18
    y: float = 0.06
    tolerance_x: float = 0.025
    tolerance_y: float = 0.02
    tolerance_yaw: float = math.radians(6.0)


def choose_foot(robot: GroundPose, ball: tuple[float, float], direction: float) -> str:
    """"left" if the ball lies left of the line through the robot along the kick direction, else "right"."""
    c, s = math.cos(direction), math.sin(direction)
    dx, dy = ball[0] - robot.x, ball[1] - robot.y
    return "left" if -s * dx + c * dy >= 0.0 else "right"


def stand_pose(ball: tuple[float, float], direction: float, foot: str, spot: KickSpot) -> GroundPose:
    """Where the robot stands to kick the ball along ``direction`` with ``foot``."""
    lateral = spot.y if foot == "left" else -spot.y
    c, s = math.cos(direction), math.sin(direction)
    return GroundPose(ball[0] - (c * spot.x - s * lateral), ball[1] - (s * spot.x + c * lateral), direction)


@dataclass(frozen=True)
class Error:
    """How far the robot is from where it must stand, in its own frame."""

    forward: float
    left: float
    turn: float

    def within(self, spot: KickSpot, scale: float = 1.0) -> bool:
        return (abs(self.forward) <= spot.tolerance_x * scale and abs(self.left) <= spot.tolerance_y * scale
                and abs(self.turn) <= spot.tolerance_yaw * scale)


def error(robot: GroundPose, goal: GroundPose) -> Error:
    forward, left = robot.relative(goal.x, goal.y)
    return Error(forward, left, wrap(goal.yaw - robot.yaw))


def walk_command(err: Error, ball_ahead: float, max_speed: float, max_turn: float, gain: float = 1.5
                 ) -> tuple[float, float, float]:
    """cmd_vel (forward, left, turn) towards the stand pose; never forward into the ball while still beside the
    line (``ball_ahead``: the ball's distance in front of the robot, m)."""
    vx = max(-max_speed, min(max_speed, gain * err.forward))
    vy = max(-max_speed, min(max_speed, gain * err.left))
    vyaw = max(-max_turn, min(max_turn, gain * err.turn))
    if ball_ahead < 0.35 and abs(err.left) > 0.05 and vx > 0:
        vx = 0.0  # sideways first: walking forward now would push the ball with a foot
    return vx, vy, vyaw


class BallTrack:
    """The ball in the odometry frame: the mean of its recent sightings (they scatter by the vision's noise)."""

    def __init__(self, keep: int = 10, jump: float = 0.4) -> None:
        self.sightings: deque[tuple[float, float, float]] = deque(maxlen=keep)  # (time, x, y)
        self.jump = jump

    def add(self, now: float, x: float, y: float) -> None:
        est = self.estimate()
        if est is not None and math.hypot(x - est[0], y - est[1]) > self.jump:
            self.sightings.clear()  # it moved (pushed or kicked): start again from here
        self.sightings.append((now, x, y))

    def estimate(self, since: float = -math.inf) -> tuple[float, float] | None:
        """The mean of the sightings since ``since`` (of all kept, if none is that new)."""
        chosen = [s for s in self.sightings if s[0] >= since] or list(self.sightings)
        if not chosen:
            return None
        return sum(s[1] for s in chosen) / len(chosen), sum(s[2] for s in chosen) / len(chosen)

    def last_seen(self) -> float:
        return self.sightings[-1][0] if self.sightings else -math.inf

    def count_since(self, t: float) -> int:
        return sum(1 for s in self.sightings if s[0] >= t)
