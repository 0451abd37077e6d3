"""RoboCup GameController: the receiver node (receiver), what it tells an HSL GameController (status), the delayed
state after the whistle (fake_state) and a simulated GC (simulator); the codec is wire.gamecontroller's, re-exported
here."""

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
