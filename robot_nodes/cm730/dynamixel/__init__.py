"""Dynamixel servo bus backend (Protocol 1.0 via CM-730, Protocol 2.0) for the cm730 node."""

from __future__ import annotations

from .backend import DynamixelBackend, DynamixelError, open_backend
from .config import BITBOTS_JOINTS, BusConfig, ConfigError, JointConfig, default_joints, joints_from_dict
from .models import MODELS, ServoModel, UnknownServoModel

__all__ = [
    "BITBOTS_JOINTS", "MODELS", "BusConfig", "ConfigError", "DynamixelBackend", "DynamixelError",
    "JointConfig", "ServoModel", "UnknownServoModel", "default_joints", "joints_from_dict", "open_backend",
]
