"""What the routers share (hub, config, sources, Zenoh link), handed to them by dependency injection."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from server.config import ServerConfig
from server.hub import Hub
from server.sources import SourceSet
from server.zenoh_link import ZenohLink


@dataclass(slots=True)
class ServerState:
    config: ServerConfig
    hub: Hub
    sources: SourceSet
    link: ZenohLink
    views: dict[str, Any] = field(default_factory=dict)  # optional feeders: "robot3d", "plots"
    telemetry_key: str = ""  # what the page shows of the key: "development" or a team key's fingerprint
