"""The HSL team-message budget: how fast one robot may send so its team does not run out before the final whistle.

The HSL GameController gives each team a budget (12,000 messages per game in 2026, 600 more per minute of extra
time), counts every team message it hears on port 10000 + team number in READY, SET and PLAYING, and reports the
budget left in every packet; a message sent with budget 0 is illegal. A robot spreads what is left evenly over the
game time left and its team's robots, keeping a reserve for stoppages: with 12,000 messages, 7 robots and two
10-minute halves, 12,000 x 0.9 / (7 x 1,200 s) = 1.29 messages per second each.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

from wire.gamecontroller.game_data import HSL_MAX_PAYLOAD, HSL_TEAM_PORT_BASE

__all__ = ["BUDGET_UNKNOWN", "HSL_MAX_PAYLOAD", "HSL_TEAM_PORT_BASE", "BudgetPacer", "budget_rate_hz", "game_left_s",
           "team_port"]
BUDGET_UNKNOWN = 65_535  # GameState.MESSAGE_BUDGET_UNKNOWN: the GameController (HL v12) keeps no budget
MIN_GAME_LEFT_S = 60.0  # the end of a game does not turn the budget left into a burst
_PLAYING_STATES = (1, 2, 3)  # READY, SET, PLAYING: where the GameController counts
_PENALTY_SHOOT_OUT = 1
_SLACK = 0.02  # a tick a little early still sends (the bucket would otherwise skip it and send two later)


def team_port(team_number: int) -> int:
    return HSL_TEAM_PORT_BASE + team_number


def game_left_s(secs_remaining: float, first_half: bool, half_s: float) -> float:
    """Seconds of play left in the game: this half's and, in the first half, the whole second half."""
    return max(0.0, float(secs_remaining)) + (half_s if first_half else 0.0)


def budget_rate_hz(budget_left: int, robots: int, left_s: float, reserve: float) -> float:
    """Messages per second one robot may send: the budget left, less the reserve, over robots and time left."""
    if budget_left <= 0:
        return 0.0
    return budget_left * (1.0 - reserve) / (max(1, robots) * max(MIN_GAME_LEFT_S, left_s))


@dataclass
class BudgetPacer:
    """Decides tick by tick whether to send (a token bucket filled at the allowed rate, so sends are even)."""

    half_s: float = 600.0
    reserve: float = 0.1
    window_s: float = 10.0
    credit: float = 1.0
    allowed_rate_hz: float | None = None  # None: no budget to keep (HL v12, no GameController)
    budget_left: int = BUDGET_UNKNOWN
    held_back: int = 0  # ticks on which the budget said no
    _last: float | None = None
    _sent: deque[float] = field(default_factory=deque)

    def update(self, budget_left: int, robots: int, secs_remaining: float, first_half: bool, game_state: int,
               game_phase: int) -> None:
        """From the newest GameState (message_budget, players_per_team, clocks, state and phase)."""
        self.budget_left = budget_left
        if budget_left == BUDGET_UNKNOWN:
            self.allowed_rate_hz = None
        elif budget_left <= 0:
            self.allowed_rate_hz = 0.0
        elif game_state not in _PLAYING_STATES or game_phase == _PENALTY_SHOOT_OUT:
            self.allowed_rate_hz = None  # not counted here (INITIAL, FINISHED, a shoot-out)
        else:
            self.allowed_rate_hz = budget_rate_hz(budget_left, robots, game_left_s(secs_remaining, first_half,
                                                                                     self.half_s), self.reserve)

    def may_send(self, now: float, max_rate_hz: float) -> bool:
        """True if a message may go now; counts it as sent."""
        dt = 0.0 if self._last is None else max(0.0, now - self._last)
        self._last = now
        if self.budget_left == 0:
            self.credit = 0.0
            self.held_back += 1
            return False
        if self.allowed_rate_hz is None or self.allowed_rate_hz >= max_rate_hz:
            self.credit = 1.0  # nothing to keep: every tick sends (a timer that fires a little early included)
        else:
            self.credit = min(2.0, self.credit + self.allowed_rate_hz * dt)
            if self.credit < 1.0 - _SLACK or self.allowed_rate_hz <= 0:
                self.held_back += 1
                return False
        self.credit = max(0.0, self.credit - 1.0)
        self._sent.append(now)
        return True

    def send_rate_hz(self, now: float) -> float:
        """Messages per second sent over the last window_s."""
        while self._sent and now - self._sent[0] > self.window_s:
            self._sent.popleft()
        return len(self._sent) / self.window_s
