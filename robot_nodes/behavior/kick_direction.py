"""Which way to kick: at the part of the goal mouth no robot covers, unless a robot stands on that line beyond the
ball, then past it.

In a match the two strikers meet face to face at the ball, and a straight kick stops at the other one's feet (the
kick trials: 0 of 6 balls went with a rival 0.35 m beyond the ball on the line, 4 of 4 went 2.6-3.0 m when kicked
40 deg past him). Everything is relative to the robot (base_footprint: x forward, y left), as the perception gives
the ball and the obstacles."""

from __future__ import annotations

import math
from collections.abc import Sequence

SIDE_ANGLE = math.radians(40.0)  # how far past a blocking robot the ball is sent
CLEARANCE = 0.2  # m: a robot's centre nearer than this to the ball's line blocks it (half a Minibot + the ball)
REACH = 1.2  # m beyond the ball: robots farther away are not in the way of a kick yet


def blocked(ball: tuple[float, float], direction: float, obstacles: Sequence[tuple[float, float]]) -> bool:
    """A robot stands on the line from the ball along ``direction``, within REACH beyond it."""
    c, s = math.cos(direction), math.sin(direction)
    for ox, oy in obstacles:
        dx, dy = ox - ball[0], oy - ball[1]
        along, across = c * dx + s * dy, -s * dx + c * dy
        if 0.0 < along < REACH and abs(across) < CLEARANCE:
            return True
    return False


def kick_direction(ball: tuple[float, float], toward: float, obstacles: Sequence[tuple[float, float]]) -> float:
    """``toward`` (the goal's direction, rad) if that line is clear; else SIDE_ANGLE to the side away from the
    nearest blocking robot, or to the other side; ``toward`` again when every line is blocked."""
    if not blocked(ball, toward, obstacles):
        return toward
    c, s = math.cos(toward), math.sin(toward)
    in_way = [(ox, oy) for ox, oy in obstacles if blocked(ball, toward, [(ox, oy)])]
    nearest = min(in_way, key=lambda o: math.hypot(o[0] - ball[0], o[1] - ball[1]))
    left_of_line = -s * (nearest[0] - ball[0]) + c * (nearest[1] - ball[1]) > 0.0
    sides = (-SIDE_ANGLE, SIDE_ANGLE) if left_of_line else (SIDE_ANGLE, -SIDE_ANGLE)
    for side in sides:
        if not blocked(ball, toward + side, obstacles):
            return toward + side
    return toward


def clearance(ball: tuple[float, float], target: tuple[float, float],
              obstacles: Sequence[tuple[float, float]]) -> float:
    """How far (m) the nearest robot between the ball and ``target`` stands from that line (inf: none there)."""
    dx, dy = target[0] - ball[0], target[1] - ball[1]
    length = math.hypot(dx, dy)
    if length < 1e-6:
        return math.inf
    c, s = dx / length, dy / length
    nearest = math.inf
    for ox, oy in obstacles:
        rx, ry = ox - ball[0], oy - ball[1]
        if 0.0 < c * rx + s * ry < length:
            nearest = min(nearest, abs(-s * rx + c * ry))
    return nearest


def aim_in_goal(ball: tuple[float, float], mouth: Sequence[tuple[float, float]],
                obstacles: Sequence[tuple[float, float]]) -> float:
    """The direction (rad) from the ball to the point of the goal mouth (``mouth``: points between the posts, the
    middle first) whose line passes farthest from every robot seen; the middle when none is in the way. A goalie
    stands on the line from the ball to the goal's centre (its job): a kick at the centre goes to its feet."""
    best = max(mouth, key=lambda point: min(clearance(ball, point, obstacles), 1.0))
    return math.atan2(best[1] - ball[1], best[0] - ball[0])
