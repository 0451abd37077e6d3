"""A secured team's one shared secret, ``team.key``, and how a command knows it runs on a secured team.

`pitchside team-keys` writes team.key beside the members' Zenoh configs: 256 random bits, the telemetry key of
the robots and the dashboard, and the root the team communication derives its signing key from
(robot_nodes.mitecom.signing). A Zenoh config with mutual TLS is a secured team's: on such a team no command may
fall back to the published development key, since the bus it protects would then be bypassed by UDP.
"""

from __future__ import annotations

import json
from pathlib import Path

from wire.bus import load_config_file

TEAM_KEY_FILE = "team.key"


def secured_bus(config_file: str | Path) -> bool:
    """Whether a Zenoh config file is a secured team's: its links need mutual TLS (as team-keys writes them).

    ValueError if the file is missing or not a Zenoh config."""
    conf = load_config_file(config_file)
    return json.loads(conf.get_json("transport/link/tls/enable_mtls") or "null") is True


def team_key_beside(config_file: str | Path) -> Path | None:
    """team.key in the folder of a member's config file (where team-keys writes both), if it is there."""
    path = Path(config_file).expanduser().resolve().parent / TEAM_KEY_FILE
    return path if path.is_file() else None
