"""RoboCup GameController: the receiver node (receiver), what it tells an HSL GameController (status) and the delayed
state after the whistle (fake_state); the codec is wire.gamecontroller's, re-exported here. A simulated GameController
lives with the simulation (robot_nodes/sim/gamecontroller.py)."""

from wire.gamecontroller.packets import (
    GameControlData,
    GameControllerPacketError,
    GameStateValue,
    Penalty,
    ReturnMessage,
    ReturnPacket,
    RobotInfo,
    SecondaryState,
    TeamInfo,
    build_return_packet,
    build_state_packet,
    parse_return_packet,
    parse_state_packet,
)

__all__ = [
    "GameControlData",
    "GameControllerPacketError",
    "GameStateValue",
    "Penalty",
    "ReturnMessage",
    "ReturnPacket",
    "RobotInfo",
    "SecondaryState",
    "TeamInfo",
    "build_return_packet",
    "build_state_packet",
    "parse_return_packet",
    "parse_state_packet",
]
