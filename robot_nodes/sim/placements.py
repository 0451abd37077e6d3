"""Where robots and the ball stand in a simulated match: kick-off positions, the touch line, penalties, set plays.

Robot spots are written in the team's own frame (x towards the goal it attacks, y to the left, its own goal at
x = -4.5) and turned into field coordinates for the team's end (robot_nodes/sim/lineup.py). The Humanoid
League rules name where robots start, where a penalised robot waits and comes back, and where the ball is put for a
set play; these are our readings of them (the README's list of simplifications says where we simplified).
"""

from __future__ import annotations

import math

from robot_nodes.sim.field import KID_SIZE, FieldDimensions
from robot_nodes.sim.lineup import Lineup, Team
from robot_nodes.sim.scene import Placement

ROBOT_RADIUS = 0.15  # m, about a Minibot's footprint
# kick-off positions by player number (1 is the goalkeeper), own frame; player 2 of the kicking team at the ball
_KICK_OFF = [(-4.2, 0.0), (-0.35, 0.0), (-1.6, 1.2), (-1.6, -1.2), (-2.8, 0.0), (-2.8, 1.8), (-2.8, -1.8),
             (-1.0, 2.3), (-1.0, -2.3), (-3.6, 1.2), (-3.6, -1.2)]
DEFENDING_STRIKER_X = -1.1  # player 2 of the team not kicking off: outside the centre circle


def to_field(team: Team, x: float, y: float, yaw: float = 0.0) -> Placement:
    """A spot of the team's own frame in field coordinates."""
    if team.attack > 0:
        return Placement(x, y, yaw)
    return Placement(-x, -y, math.atan2(math.sin(yaw + math.pi), math.cos(yaw + math.pi)))


def to_team(team: Team, x: float, y: float) -> tuple[float, float]:
    """A field point in the team's own frame."""
    return (x, y) if team.attack > 0 else (-x, -y)


def kick_off(team: Team, player: int, kicking: bool) -> Placement:
    """A legal kick-off position in the own half, facing the opponent goal."""
    x, y = _KICK_OFF[(player - 1) % len(_KICK_OFF)]
    if player == 2 and not kicking:
        x = DEFENDING_STRIKER_X
    return to_field(team, x, y)


def touch_line(team: Team, player: int, f: FieldDimensions = KID_SIZE) -> Placement:
    """Where a robot stands in INITIAL: on a touch line of the own half (odd players left, even right, seen from
    the own goal), facing into the field, ready to walk in when READY begins."""
    side = 1.0 if player % 2 else -1.0
    x = -(0.6 + 0.7 * ((player - 1) // 2))
    return to_field(team, x, side * f.width / 2, -side * math.pi / 2)


def penalty_box(team: Team, player: int, f: FieldDimensions = KID_SIZE) -> Placement:
    """Where a penalised robot waits: outside the field beyond the touch line of its own half, facing the field."""
    side = 1.0 if player % 2 else -1.0
    x = -(0.4 + 0.37 * (player - 1))
    return to_field(team, x, side * (f.width / 2 + 0.6), -side * math.pi / 2)


def comeback(team: Team, player: int, ball_xy: tuple[float, float], f: FieldDimensions = KID_SIZE) -> Placement:
    """Where a robot comes back after its penalty: on the touch line at the height of its own penalty mark, on the
    side away from the ball, facing into the field (spread a little by player number, so two never meet)."""
    _, ball_y = to_team(team, *ball_xy)
    side = -1.0 if ball_y > 0 else 1.0
    x = -(f.length / 2 - f.penalty_mark_distance) + 0.35 * ((player - 1) % 3 - 1)
    return to_field(team, x, side * f.width / 2, -side * math.pi / 2)


def legal_at_kick_off(team: Team, x: float, y: float, kicking: bool, f: FieldDimensions = KID_SIZE) -> bool:
    """Inside the field, in the own half (the centre line counts), and outside the centre circle unless kicking off."""
    tx, ty = to_team(team, x, y)
    if abs(tx) > f.length / 2 or abs(ty) > f.width / 2 or tx > 0.05:
        return False
    return kicking or math.hypot(tx, ty) >= f.centre_circle_diameter / 2


def throw_in_spot(x: float, y: float, f: FieldDimensions = KID_SIZE) -> tuple[float, float]:
    """The ball left over a touch line at (x, y): back on that touch line where it left, at least 0.5 m from a
    goal line."""
    limit = f.length / 2 - 0.5
    return max(-limit, min(limit, x)), math.copysign(f.width / 2, y)


def goal_kick_spot(goal_sign: int, y: float, f: FieldDimensions = KID_SIZE) -> tuple[float, float]:
    """A goal kick at the goal at ``goal_sign`` (x): the front corner of its goal area on the side the ball left."""
    return goal_sign * (f.length / 2 - f.goal_area_length), math.copysign(f.goal_area_width / 2, y)


def corner_spot(goal_sign: int, y: float, f: FieldDimensions = KID_SIZE) -> tuple[float, float]:
    """A corner kick at the goal at ``goal_sign``: the field's corner on the side the ball left."""
    return goal_sign * f.length / 2, math.copysign(f.width / 2, y)


def lineup_start(lineup: Lineup, f: FieldDimensions = KID_SIZE) -> list[Placement]:
    """Every robot of the lineup on its touch line, in the lineup's robot order (home1.., away1..)."""
    return [touch_line(team, player, f) for team in lineup.teams for player in range(1, team.players + 1)]
