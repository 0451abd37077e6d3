"""Opening the Zenoh session: one per process, endpoints from config, no multicast."""

from __future__ import annotations

import json
import logging
import os
import time
from dataclasses import dataclass, field

import zenoh

DEFAULT_ROUTER = "tcp/127.0.0.1:7447"
ENV_CONNECT = "PITCHSIDE_CONNECT"
log = logging.getLogger(__name__)


@dataclass(slots=True)
class BusConfig:
    """Where a process finds the rest of the team.

    The default is a peer that connects to a router on loopback and listens on a random loopback port,
    so peers that learn of each other through the router (gossip) talk directly. Multicast scouting is
    off: nothing depends on the network passing multicast, and tests stay on loopback.
    """

    connect: list[str] = field(default_factory=lambda: _env_endpoints() or [DEFAULT_ROUTER])
    listen: list[str] = field(default_factory=lambda: ["tcp/127.0.0.1:0"])
    mode: str = "peer"
    config_file: str | None = None

    def to_zenoh(self) -> zenoh.Config:
        conf = zenoh.Config.from_file(self.config_file) if self.config_file else zenoh.Config()
        if not self.config_file:
            conf.insert_json5("mode", json.dumps(self.mode))
            conf.insert_json5("connect/endpoints", json.dumps(self.connect))
            conf.insert_json5("listen/endpoints", json.dumps(self.listen if self.mode != "client" else []))
            conf.insert_json5("scouting/multicast/enabled", "false")
            # keep trying in the background: robots often boot before the router or the team PC
            conf.insert_json5("connect/exit_on_failure", "false")
            conf.insert_json5("connect/timeout_ms", "2000")
        return conf


def _env_endpoints() -> list[str]:
    value = os.environ.get(ENV_CONNECT, "")
    return [e.strip() for e in value.split(",") if e.strip()]


def open_session(bus: BusConfig | None = None, wait: bool = True) -> zenoh.Session:
    """A peer opens at once; a client needs its router and, with wait, keeps trying until it is there."""
    bus = bus or BusConfig()
    while True:
        try:
            return zenoh.open(bus.to_zenoh())
        except zenoh.ZError as exc:
            if not wait:
                raise
            log.warning("Zenoh router %s not reachable yet (%s); retrying", ", ".join(bus.connect), exc)
            time.sleep(0.5)


def open_router(listen: list[str], connect: list[str] | None = None) -> zenoh.Session:
    """A Zenoh router inside this process: robots and dashboards connect to it by endpoint."""
    conf = zenoh.Config()
    conf.insert_json5("mode", '"router"')
    conf.insert_json5("listen/endpoints", json.dumps(listen))
    conf.insert_json5("connect/endpoints", json.dumps(connect or []))
    conf.insert_json5("scouting/multicast/enabled", "false")
    return zenoh.open(conf)
