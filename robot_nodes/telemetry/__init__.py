"""One-way UDP telemetry: the robot's sender node, the shared datagram format and the team PC's receiver."""

from robot_nodes.telemetry.estimate import estimate_bandwidth
from robot_nodes.telemetry.sender import TelemetryNode
from wire.telemetry.datagram import DEFAULT_PORT, TelemetryError, decode_overview, encode_overview, new_overview
from wire.telemetry.receiver import (
    ReceivedMessage,
    RobotHealth,
    StreamHealth,
    TelemetryListener,
    TelemetryReceiver,
    listen,
)

__all__ = [
    "DEFAULT_PORT",
    "ReceivedMessage",
    "RobotHealth",
    "StreamHealth",
    "TelemetryError",
    "TelemetryListener",
    "TelemetryNode",
    "TelemetryReceiver",
    "decode_overview",
    "encode_overview",
    "estimate_bandwidth",
    "listen",
    "new_overview",
]
