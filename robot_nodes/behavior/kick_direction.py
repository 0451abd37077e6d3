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


def _along_across(ball: tuple[float, float], direction: float,
                  obstacles: Sequence[tuple[float, float]]) -> list[tuple[float, float]]:
    """Each robot's place on the line from the ball along ``direction``: (how far along it, how far beside it), m."""
    c, s = math.cos(direction), math.sin(direction)
    return [(c * (ox - ball[0]) + s * (oy - ball[1]), -s * (ox - ball[0]) + c * (oy - ball[1]))
            for ox, oy in obstacles]


def _in_way(along: float, across: float) -> bool:
    return 0.0 < along < REACH and abs(across) < CLEARANCE


def blocked(ball: tuple[float, float], direction: float, obstacles: Sequence[tuple[float, float]]) -> bool:
    """A robot stands on the line from the ball along ``direction``, within REACH beyond it."""
    return any(_in_way(along, across) for along, across in _along_across(ball, direction, obstacles))


def kick_direction(ball: tuple[float, float], toward: float, obstacles: Sequence[tuple[float, float]]) -> float:
    """``toward`` (the goal's direction, rad) if that line is clear; else SIDE_ANGLE to the side away from the
    nearest blocking robot, or to the other side; ``toward`` again when every line is blocked."""
    in_way = [place for place in _along_across(ball, toward, obstacles) if _in_way(*place)]
    if not in_way:
        return toward
    _, nearest_across = min(in_way, key=lambda place: math.hypot(*place))
    sides = (-SIDE_ANGLE, SIDE_ANGLE) if nearest_across > 0.0 else (SIDE_ANGLE, -SIDE_ANGLE)
    for side in sides:
        if not blocked(ball, toward + side, obstacles):
            return toward + side
    return toward


def clearance(ball: tuple[float, float], target: tuple[float, float],
              obstacles: Sequence[tuple[float, float]]) -> float:
    """How far (m) the nearest robot between the ball and ``target`` stands from that line (inf: none there)."""
    length = math.hypot(target[0] - ball[0], target[1] - ball[1])
    direction = math.atan2(target[1] - ball[1], target[0] - ball[0])
    return min((abs(across) for along, across in _along_across(ball, direction, obstacles) if 0.0 < along < length),
               default=math.inf)


def aim_in_goal(ball: tuple[float, float], mouth: Sequence[tuple[float, float]],
                obstacles: Sequence[tuple[float, float]]) -> float:
    """The direction (rad) from the ball to the point of the goal mouth (``mouth``: points between the posts, the
    middle first) whose line passes farthest from every robot seen; the middle when none is in the way. A goalie
    stands on the line from the ball to the goal's centre (its job): a kick at the centre goes to its feet."""
    best = max(mouth, key=lambda point: min(clearance(ball, point, obstacles), 1.0))
    return math.atan2(best[1] - ball[1], best[0] - ball[0])
