"""Pause logic: merges the GameController's penalty and the manual_penalize service into `paused`.

A manual penalty overrides the GameController, not the reverse: paused = manual penalty OR GameController penalty.
The manual penalty alone goes out on `manual_penalty`, so the game_controller node tells the GameController in its
return packets (MAN_PENALISE, then MAN_UNPENALISE when it ends), as the rules want a robot's button to.

    python -m robot_nodes.hcm.pause
"""

from __future__ import annotations

import schemas
from robot_nodes.runtime import Node, run
from schemas.messages import GameState, ManualPenalizeRequest, ManualPenalizeResponse
from schemas.std import Bool


class PauseNode(Node):
    """Decides whether the robot is paused (penalized)."""

    name = "pause"

    def setup(self) -> None:
        self.manual = False
        self.game_controller = False
        self.paused_pub = self.publisher("paused")
        self.manual_pub = self.publisher("manual_penalty")
        self.subscribe("gamestate", self.on_gamestate)
        self.service("manual_penalize", self.on_manual_penalize)
        self.timer(self.publish, rate_hz=2.0)
        self.publish()

    @property
    def paused(self) -> bool:
        return self.manual or self.game_controller

    def on_gamestate(self, msg: GameState) -> None:
        before = self.paused
        self.game_controller = bool(msg.penalized)
        if self.paused != before:
            self.publish()

    def on_manual_penalize(self, request: ManualPenalizeRequest) -> ManualPenalizeResponse:
        if request.penalize == ManualPenalizeRequest.ON:
            self.manual = True
        elif request.penalize == ManualPenalizeRequest.OFF:
            self.manual = False
        elif request.penalize == ManualPenalizeRequest.SWITCH:
            self.manual = not self.manual
        else:
            raise ValueError(f"penalize must be OFF (0), ON (1) or SWITCH (2), not {request.penalize}")
        self.publish()
        return schemas.make(ManualPenalizeResponse, penalized=self.paused)

    def publish(self) -> None:
        self.paused_pub.publish(schemas.make(Bool, data=self.paused))
        self.manual_pub.publish(schemas.make(Bool, data=self.manual))
        self.set_diagnostic("manual", self.manual)
        self.set_diagnostic("game_controller", self.game_controller)


if __name__ == "__main__":
    run(PauseNode)
