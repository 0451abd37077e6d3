"""One-way UDP telemetry: the robot's sender node, the shared datagram format and the team PC's receiver."""

from robot_nodes.telemetry.datagram import DEFAULT_PORT, RobotOverview, TelemetryError
from robot_nodes.telemetry.estimate import estimate_bandwidth
from robot_nodes.telemetry.receiver import (
    ReceivedMessage,
    RobotHealth,
    StreamHealth,
    TelemetryListener,
    TelemetryReceiver,
    listen,
)
from robot_nodes.telemetry.sender import TelemetryNode

__all__ = [
    "DEFAULT_PORT",
    "ReceivedMessage",
    "RobotHealth",
    "RobotOverview",
    "StreamHealth",
    "TelemetryError",
    "TelemetryListener",
    "TelemetryNode",
    "TelemetryReceiver",
    "estimate_bandwidth",
    "listen",
]
