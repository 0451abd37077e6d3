"""The GameController's "fake" state after the whistle, and how a robot that hears the whistle itself plays on.

The HSL GameController (like the HL one before it with its delayed switch to PLAYING) keeps sending the state
before an event for up to 10 s after the referee switched to PLAYING, or until an event happens that the old state
cannot have. Robots are meant to start on the referee's whistle. So when the robot's whistle detector (topic
`whistle`) hears it while the GameController still says SET, the robot takes PLAYING at once and keeps it while the
GameController goes on saying SET, for at most ``hold_s``: the GameController's own PLAYING confirms it; any other
state (READY, INITIAL, FINISHED) contradicts it; if SET is still sent after ``hold_s`` the whistle was not the
kick-off's (another field's, a false detection) and the GameController's SET counts again.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from wire.gamecontroller.game_data import GameStateValue

HOLD_S = 10.0  # the HSL GameController's README: the previous state for up to 10 s


@dataclass
class WhistleStart:
    hold_s: float = HOLD_S
    heard_at: float | None = None  # the whistle that started PLAYING ahead of the GameController
    confirmed: int = 0
    contradicted: int = 0
    expired: int = 0

    def on_whistle(self, now: float, gc_state: int | None) -> bool:
        """A whistle: PLAYING ahead of the GameController if it says SET; True if that changes what is told."""
        if self.hold_s <= 0 or gc_state != GameStateValue.SET or self.heard_at is not None:
            return False
        self.heard_at = now
        return True

    def apply(self, fields: dict[str, Any], now: float) -> dict[str, Any]:
        """The GameState fields to publish: the GameController's, or PLAYING while a whistle holds."""
        if self.heard_at is None:
            return fields
        state = fields["game_state"]
        if state != GameStateValue.SET:
            if state == GameStateValue.PLAYING:
                self.confirmed += 1
            else:
                self.contradicted += 1
            self.heard_at = None
            return fields
        if now - self.heard_at > self.hold_s:
            self.expired += 1
            self.heard_at = None
            return fields
        return fields | {"game_state": int(GameStateValue.PLAYING), "state_from_whistle": True,
                         "allowed_to_move": not fields["penalized"] and not fields["stopped"]}
