"""Roles by team communication: player 1 keeps the goal; of the field players the one with the shortest time to the
ball is the striker (the present striker keeps it unless another is clearly faster); the rest defend (the one nearest
the own goal; the two nearest when five or more field players play, as in the HSL's 7 v 7) and support. Everyone
decides for itself from team_data, so all agree while they hear each other."""

from __future__ import annotations

import math
from dataclasses import dataclass

from robot_nodes.behavior.world_model import Teammate
from schemas.messages import Strategy

GOALIE, STRIKER, SUPPORTER, DEFENDER = (Strategy.ROLE_GOALIE, Strategy.ROLE_STRIKER, Strategy.ROLE_SUPPORTER,
                                        Strategy.ROLE_DEFENDER)
ROLE_NAMES = {GOALIE: "goalie", STRIKER: "striker", SUPPORTER: "supporter", DEFENDER: "defender",
              Strategy.ROLE_IDLING: "idling", Strategy.ROLE_OTHER: "other"}
GOALIE_PLAYER = 1
TWO_DEFENDERS_FROM = 5  # field players heard (this robot included)


@dataclass(frozen=True)
class Candidate:
    """A field player as the role choice sees it."""

    player: int
    time_to_ball: float  # s; inf when it does not know where the ball is
    x: float | None  # on the field (own goal at -x); None when it does not know
    striker_now: bool = False


def time_to_ball(distance: float, speed: float) -> float:
    """The team's shared estimate (the Mitecom node sends the same: distance over walking speed)."""
    return distance / speed if math.isfinite(distance) else math.inf


def assign_roles(me: Candidate, mates: list[Teammate], keep_margin_s: float) -> int:
    """This robot's role (Strategy.ROLE_*) among the teammates it hears (penalized ones do not count)."""
    if me.player == GOALIE_PLAYER:
        return GOALIE
    field = [me] + [Candidate(m.player, m.time_to_ball if m.time_to_ball is not None else math.inf,
                              m.pose.x if m.pose is not None else None, m.role == STRIKER)
                    for m in mates if m.player != GOALIE_PLAYER and not m.penalized]

    def cost(c: Candidate) -> tuple[float, int]:
        bonus = keep_margin_s if c.striker_now else 0.0  # a striker keeps its role against near ties
        return (c.time_to_ball - bonus, c.player)

    striker = min(field, key=cost)
    if striker.player == me.player:
        return STRIKER
    others = sorted((c for c in field if c.player != striker.player),
                    key=lambda c: (c.x if c.x is not None else 0.0, c.player))
    defenders = 2 if len(field) >= TWO_DEFENDERS_FROM else 1
    return DEFENDER if me.player in {c.player for c in others[:defenders]} else SUPPORTER


def ready_rank(me: int, mates: list[Teammate]) -> int:
    """This robot's place in the kick-off line-up: 0 for the goalie, then the field players by player number. A
    teammate not heard is taken to be there (each keeps its own place when the network is down); one heard to be
    penalized is not, so the next takes its place."""
    if me == GOALIE_PLAYER:
        return 0
    penalized = {m.player for m in mates if m.penalized}
    players = [n for n in range(GOALIE_PLAYER + 1, max([me, *(m.player for m in mates)]) + 1) if n not in penalized]
    return 1 + players.index(me) if me in players else len(players) + 1
