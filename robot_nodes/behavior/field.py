"""The field as the behaviour sees it: the team's frame (own goal at -x, centre mark at the origin, y to the left)
and the places of the game: the goals, the goal area, the centre circle, kick-off positions and their legality."""

from __future__ import annotations

import math
from dataclasses import dataclass

GOAL_AIM_BEYOND = 0.5  # m behind the goal line (a kid-size goal is 0.6 m deep)
# the supporter's place relative to the ball: ahead of it and beside its line to the goal, where a kick sent 40 deg
# past a blocking rival (2.6-3.0 m, behavior/kick_direction.py) lands, about 2.1 m ahead and 1.8 m aside
SUPPORT_AHEAD = 1.5  # m towards the opponent goal
SUPPORT_BESIDE = 1.2  # m to the side of the field's middle
SUPPORT_GOAL_CLEARANCE = 1.2  # m: it stays this far in front of the opponent goal line (out of the goalie's way)


@dataclass(frozen=True)
class Field:
    """Humanoid League kid-size dimensions by default (the behaviour's parameters set them)."""

    length: float = 9.0
    width: float = 6.0
    goal_width: float = 2.6
    goal_area_length: float = 1.0
    goal_area_width: float = 3.0
    centre_circle_diameter: float = 1.5

    @property
    def own_goal(self) -> tuple[float, float]:
        return -self.length / 2, 0.0

    @property
    def opponent_goal(self) -> tuple[float, float]:
        return self.length / 2, 0.0

    @property
    def shot_target(self) -> tuple[float, float]:
        """Where a shot at the opponent goal is meant to end: inside it, GOAL_AIM_BEYOND behind the line. Aimed at
        the line itself, a ball near the line was kicked along it (a match's ball lay 5 cm short of a goal for 45 s
        while the striker lined up sideways to it)."""
        gx, gy = self.opponent_goal
        return gx + GOAL_AIM_BEYOND, gy

    def in_own_half(self, x: float, margin: float = 0.0) -> bool:
        return x <= -margin

    def outside_centre_circle(self, x: float, y: float, margin: float = 0.0) -> bool:
        return math.hypot(x, y) >= self.centre_circle_diameter / 2 + margin

    def in_own_goal_area(self, x: float, y: float) -> bool:
        return x <= -self.length / 2 + self.goal_area_length and abs(y) <= self.goal_area_width / 2

    def clamp_inside(self, x: float, y: float, margin: float = 0.3) -> tuple[float, float]:
        """A point inside the field lines, ``margin`` away from them."""
        hx, hy = self.length / 2 - margin, self.width / 2 - margin
        return min(max(x, -hx), hx), min(max(y, -hy), hy)


def support_place(field: Field, ball: tuple[float, float]) -> tuple[float, float, float]:
    """The supporter's place (x, y, heading to the ball): SUPPORT_AHEAD of the ball towards the opponent goal and
    SUPPORT_BESIDE towards the field's middle, inside the field. Behind the ball (where it stood before) it only
    watched the two strikers kick the ball to and fro in midfield; ahead, it is the nearer robot when a kick gets
    past the rival striker, so it becomes the striker there, nearer the goal than any rival field player."""
    side = -1.0 if ball[1] > 0 else 1.0
    x, y = field.clamp_inside(ball[0] + SUPPORT_AHEAD, ball[1] + side * SUPPORT_BESIDE, 0.4)
    x = min(x, field.length / 2 - SUPPORT_GOAL_CLEARANCE)
    return x, y, math.atan2(ball[1] - y, ball[0] - x)


def ready_legal(field: Field, x: float, y: float, kicking_off: bool, margin: float = 0.0) -> bool:
    """A robot's place at the end of READY (Humanoid League rules): in its own half, and outside the centre circle
    unless its team kicks off (the kicker may stand in its half of the circle)."""
    return field.in_own_half(x, margin) and (kicking_off or field.outside_centre_circle(x, y, margin))


def kickoff_positions(field: Field, kicking_off: bool) -> list[tuple[float, float, float]]:
    """READY targets (x, y, heading), by rank: the goalie first, then the field players in the order they take them.

    Kicking off, the first field player stands behind the ball in the centre circle; defending, every field player
    keeps 0.45 m clear of the circle. All stay 0.3 m inside the own half, heading for the opponent goal."""
    goal_x = -field.length / 2
    r = field.centre_circle_diameter / 2
    goalie = (goal_x + 0.5, 0.0, 0.0)
    # six field players: the HSL's Small Advanced plays 7 v 7 (a seventh robot takes the last place)
    if kicking_off:
        players = [(-0.35, 0.0, 0.0), (-1.0, -1.5, 0.0), (-2.5, 0.8, 0.0), (-1.5, 1.8, 0.0), (-2.5, -1.8, 0.0),
                   (-3.4, 0.0, 0.0)]
    else:
        players = [(-(r + 0.45), 0.0, 0.0), (-1.6, -1.5, 0.0), (-2.6, 0.8, 0.0), (-1.6, 1.8, 0.0),
                   (-2.6, -1.8, 0.0), (-3.4, 0.0, 0.0)]
    return [goalie, *players]
