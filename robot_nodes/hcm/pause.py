"""Pause logic: merges the GameController's penalty and the manual_penalize service into `paused`.

A manual penalty overrides the GameController, not the reverse: paused = manual penalty OR GameController penalty.

    python -m robot_nodes.hcm.pause
"""

from __future__ import annotations

from typing import Any

import schemas
from robot_nodes.runtime import Node, run

REQUEST = "humanoid_league_msgs/srv/ManualPenalize_Request"
RESPONSE = "humanoid_league_msgs/srv/ManualPenalize_Response"


class PauseNode(Node):
    """Decides whether the robot is paused (penalized)."""

    name = "pause"

    def setup(self) -> None:
        self.manual = False
        self.game_controller = False
        self.paused_pub = self.publisher("paused")
        self.subscribe("gamestate", self.on_gamestate)
        self.service("manual_penalize", self.on_manual_penalize)
        self.timer(2.0, self.publish)
        self.publish()

    @property
    def paused(self) -> bool:
        return self.manual or self.game_controller

    def on_gamestate(self, msg: Any) -> None:
        before = self.paused
        self.game_controller = bool(msg.penalized)
        if self.paused != before:
            self.publish()

    def on_manual_penalize(self, request: Any) -> Any:
        consts = schemas.constants(REQUEST)
        if request.penalize == consts["ON"]:
            self.manual = True
        elif request.penalize == consts["OFF"]:
            self.manual = False
        elif request.penalize == consts["SWITCH"]:
            self.manual = not self.manual
        else:
            raise ValueError(f"penalize must be OFF (0), ON (1) or SWITCH (2), not {request.penalize}")
        self.publish()
        return schemas.make(RESPONSE, penalized=self.paused)

    def publish(self) -> None:
        self.paused_pub.publish(schemas.make("std_msgs/msg/Bool", data=self.paused))
        self.set_diagnostic("manual", self.manual)
        self.set_diagnostic("game_controller", self.game_controller)


if __name__ == "__main__":
    run(PauseNode)
