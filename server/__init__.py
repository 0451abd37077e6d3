"""The pitchside dashboard server: sources -> hub -> browser, plus the control API (off in match mode)."""

from server.app import create_app
from server.config import RobotDescription, ServerConfig
from server.hub import Hub, HubMessage

__all__ = ["Hub", "HubMessage", "RobotDescription", "ServerConfig", "create_app"]
