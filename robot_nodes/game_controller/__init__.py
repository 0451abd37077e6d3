"""RoboCup GameController: the HL v12 codec (packets), the receiver node (receiver) and a simulated GC (simulator)."""

from robot_nodes.game_controller.packets import (
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
