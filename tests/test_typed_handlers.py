"""A node's topic handler that names a message class receives that class, and a wrong class stops the node at setup."""

from __future__ import annotations

import pytest

import schemas
from robot_nodes.runtime import BusConfig, Node
from schemas.messages import GameState, RobotControlState
from schemas.std import Bool
from tests.waiting import wait_for


class StateWatcher(Node):
    """Listens to robot_state with a typed handler and says paused."""

    name = "state_watcher"

    def setup(self) -> None:
        self.states: list[RobotControlState] = []
        self.pub = self.publisher("robot_state")
        self.subscribe("robot_state", self.on_state)

    def on_state(self, msg: RobotControlState) -> None:
        self.states.append(msg)


class WrongHandler(Node):
    """Subscribes to paused (std_msgs/Bool) with a handler that expects a GameState."""

    name = "wrong_handler"

    def setup(self) -> None:
        self.subscribe("paused", self.on_paused)

    def on_paused(self, msg: GameState) -> None:
        raise AssertionError("never called")


def test_a_typed_handler_receives_its_class(bus: BusConfig) -> None:
    node = StateWatcher(bus=bus).start()
    try:
        assert wait_for(lambda: (node.pub.publish(schemas.make(RobotControlState, state=RobotControlState.FALLEN))
                                 or bool(node.states)), timeout=10)
        assert type(node.states[0]) is RobotControlState
        assert node.states[0].state == RobotControlState.FALLEN
    finally:
        node.shutdown()


def test_a_handler_for_another_class_is_refused_at_setup(bus: BusConfig) -> None:
    with pytest.raises(schemas.SchemaError, match="GameState, but paused carries std_msgs/msg/Bool"):
        WrongHandler(bus=bus)


def test_a_message_of_another_class_is_not_published(bus: BusConfig) -> None:
    node = StateWatcher(bus=bus)
    try:
        with pytest.raises(schemas.SchemaError, match="robot_state carries"):
            node.pub.publish(schemas.make(Bool, data=True))
    finally:
        node.shutdown()
