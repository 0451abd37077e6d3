"""Opening the Zenoh session: one per process, endpoints from config, no multicast."""

from __future__ import annotations

import json
import logging
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import zenoh

DEFAULT_ROUTER = "tcp/127.0.0.1:7447"
DEFAULT_LISTEN = DEFAULT_ROUTER  # where a router listens without a config: loopback only
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

    def settings(self) -> dict[str, Any]:
        """This bus as Zenoh config data (the keys of Zenoh's JSON5 config); a team config file builds on it."""
        return {
            "mode": self.mode,
            # keep trying in the background: robots often boot before the router or the team PC
            "connect": {"endpoints": list(self.connect), "exit_on_failure": False, "timeout_ms": 2000},
            "listen": {"endpoints": list(self.listen) if self.mode != "client" else []},
            "scouting": {"multicast": {"enabled": False}},
        }

    def to_zenoh(self) -> zenoh.Config:
        if self.config_file:
            return load_config_file(self.config_file)
        return zenoh.Config.from_json5(json.dumps(self.settings()))


def load_config_file(path: str | Path) -> zenoh.Config:
    """A Zenoh JSON5 config file; ValueError names the file and what is wrong with it."""
    if not Path(path).is_file():
        raise ValueError(f"Zenoh config file {path} does not exist")
    try:
        return zenoh.Config.from_file(str(path))
    except zenoh.ZError as exc:
        raise ValueError(f"Zenoh config file {path} is not valid: {exc}") from None


def _env_endpoints() -> list[str]:
    value = os.environ.get(ENV_CONNECT, "")
    return [e.strip() for e in value.split(",") if e.strip()]


def open_session(bus: BusConfig | None = None, wait: bool = True) -> zenoh.Session:
    """A peer opens at once; a client needs its router and, with wait, keeps trying until it is there."""
    bus = bus or BusConfig()
    conf = bus.to_zenoh()  # a bad config file is an error now, not a router to wait for
    while True:
        try:
            return zenoh.open(conf)
        except zenoh.ZError as exc:
            if not wait:
                raise
            where = bus.config_file or ", ".join(bus.connect)
            log.warning("Zenoh router (%s) not reachable yet (%s); retrying", where, exc)
            time.sleep(0.5)


def router_settings(listen: list[str], connect: list[str] | None = None) -> dict[str, Any]:
    """A router's Zenoh config data: robots and dashboards connect to it by endpoint, nobody finds it by multicast."""
    return {"mode": "router", "listen": {"endpoints": list(listen)}, "connect": {"endpoints": list(connect or [])},
            "scouting": {"multicast": {"enabled": False}}}


def router_config(listen: list[str] | None = None, connect: list[str] | None = None,
                  config_file: str | Path | None = None) -> zenoh.Config:
    """A router's Zenoh config; from a file (a team's router.json5: TLS, access control, endpoints), listen and
    connect, when given, replace the file's endpoints."""
    if config_file is None:
        return zenoh.Config.from_json5(json.dumps(router_settings(listen or [DEFAULT_LISTEN], connect)))
    conf = load_config_file(config_file)
    conf.insert_json5("mode", '"router"')
    if listen:
        conf.insert_json5("listen/endpoints", json.dumps(listen))
    if connect:
        conf.insert_json5("connect/endpoints", json.dumps(connect))
    return conf


def open_router(listen: list[str] | None = None, connect: list[str] | None = None,
                config_file: str | Path | None = None) -> zenoh.Session:
    """A Zenoh router inside this process: robots and dashboards connect to it by endpoint."""
    return zenoh.open(router_config(listen, connect, config_file))
