"""The pitchside dashboard server: sources -> hub -> browser, plus the control API (off in match mode).

Importing ``server`` (or any of its small modules, e.g. ``server.security.credentials`` for a command's token) loads
no web framework: ``create_app`` imports FastAPI and the routers on first use, so ``pitchside demo --help`` stays
quick.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from server.app import create_app
    from server.config import RobotDescription, ServerConfig
    from server.hub import Hub, HubMessage

_MODULE_OF = {"create_app": "app", "RobotDescription": "config", "ServerConfig": "config", "Hub": "hub",
              "HubMessage": "hub"}

__all__ = ["Hub", "HubMessage", "RobotDescription", "ServerConfig", "create_app"]


def __getattr__(name: str) -> Any:
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{module}"), name)
