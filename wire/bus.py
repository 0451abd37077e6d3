"""Opening the Zenoh session: one per process, endpoints from config, no multicast.

The topology (README, "Several machines"): every machine has one Zenoh router. A robot's router runs inside
``pitchside robot``; the team laptop's is ``pitchside router``. The processes of a machine are peers of their
machine's router and listen on loopback only, so the nodes of one robot talk to each other directly on the
robot; machines reach each other only router to router, which the robots' routers open towards the laptop's
(``--connect``). A process whose router is on another machine takes client mode (``auto``, the default): all
its traffic goes through that router. A robot whose router connects nowhere keeps its bus on the robot.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import zenoh

from wire.machine import endpoint_host, is_loopback, is_on_this_machine

DEFAULT_ROUTER = "tcp/127.0.0.1:7447"
DEFAULT_LISTEN = DEFAULT_ROUTER  # where a router listens without a config: loopback only
ENV_CONNECT = "PITCHSIDE_CONNECT"
MODES = ("auto", "peer", "client")
log = logging.getLogger(__name__)

# Link loss (a robot walking out of the Wi-Fi, a cut cable): a link that has been silent for LEASE_MS is closed on
# both ends, so the TCP connection's backed-off retransmissions never decide when data flows again; the side
# that connected tries again at most RETRY_MAX_MS after an attempt ends, so it is back within about 0.6 s + the
# handshake of the network returning.
# A small send buffer keeps what queues up during a cut to a fraction of a second of data.
LEASE_MS = 2000
KEEP_ALIVE = 4  # keep-alives per lease: one every 0.5 s
RETRY_INIT_MS = 50
RETRY_MAX_MS = 100
# an attempt to open a link gives up after this (Zenoh's default is 10 s): a SYN sent into a cut would otherwise
# wait for the kernel's backed-off retransmission; a new attempt sends a new one
OPEN_TIMEOUT_MS = 500
SEND_BUFFER_BYTES = 256 << 10


def link_settings() -> dict[str, Any]:
    """The transport settings every pitchside session and router shares (see LEASE_MS)."""
    return {"link": {"tx": {"lease": LEASE_MS, "keep_alive": KEEP_ALIVE},
                     "tcp": {"so_sndbuf": SEND_BUFFER_BYTES}},
            "unicast": {"open_timeout": OPEN_TIMEOUT_MS}}


def _connect_settings(endpoints: list[str]) -> dict[str, Any]:
    # keep trying in the background: robots often boot before the router or the team PC
    return {"endpoints": list(endpoints), "exit_on_failure": False, "timeout_ms": 2000,
            "retry": {"period_init_ms": RETRY_INIT_MS, "period_max_ms": RETRY_MAX_MS, "period_increase_factor": 2}}


@dataclass(slots=True)
class BusConfig:
    """Where a process finds the rest of the team.

    ``mode`` auto: a peer when its router is on this machine (peers of one machine meet directly on loopback),
    a client when the router is on another machine (everything through the router, which reaches every robot).
    Multicast scouting is off: nothing depends on the network passing multicast, and tests stay on loopback.
    """

    connect: list[str] = field(default_factory=lambda: env_endpoints() or [DEFAULT_ROUTER])
    listen: list[str] = field(default_factory=lambda: ["tcp/127.0.0.1:0"])
    mode: str = "auto"
    config_file: str | None = None

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"Zenoh mode {self.mode!r}: one of {', '.join(MODES)}")

    @property
    def resolved_mode(self) -> str:
        """peer or client: auto decides by where the router is."""
        if self.mode != "auto":
            return self.mode
        return "peer" if all(is_on_this_machine(e) for e in self.connect) else "client"

    def settings(self) -> dict[str, Any]:
        """This bus as Zenoh config data (the keys of Zenoh's JSON5 config); a team config file builds on it."""
        mode = self.resolved_mode
        return {
            "mode": mode,
            "connect": _connect_settings(self.connect),
            "listen": {"endpoints": list(self.listen) if mode != "client" else []},
            "scouting": {"multicast": {"enabled": False}},
            "transport": link_settings(),
            # every message carries its publisher's time: the dashboard tells live data from data delayed by a cut
            "timestamping": {"enabled": True},
        }

    def to_zenoh(self) -> zenoh.Config:
        if self.config_file:
            return load_config_file(self.config_file)
        return zenoh.Config.from_json5(json.dumps(self.settings()))

    def describe(self) -> str:
        if self.config_file:
            return f"Zenoh config {self.config_file}"
        return f"Zenoh {self.resolved_mode} connecting to {', '.join(self.connect)}"


def add_bus_arguments(parser: argparse.ArgumentParser, *, connect_help: str | None = None,
                      config_help: str | None = None) -> None:
    """--connect, --listen, --mode and --zenoh-config: the same options on every command that joins the bus."""
    parser.add_argument("--connect", action="append", default=None, metavar="ENDPOINT",
                        help=connect_help or f"the Zenoh router to join (repeatable; default ${ENV_CONNECT} or "
                                             f"{DEFAULT_ROUTER}, this machine's router)")
    parser.add_argument("--listen", action="append", default=None, metavar="ENDPOINT",
                        help="where this process listens for peers of its machine (default tcp/127.0.0.1:0)")
    parser.add_argument("--mode", choices=MODES, default="auto",
                        help="peer (meets the peers of its machine directly), client (everything through the "
                             "router), auto (default: peer if the router is on this machine, else client)")
    parser.add_argument("--zenoh-config", default=None, metavar="FILE",
                        help=config_help or "a Zenoh JSON5 config (e.g. a member's file from `pitchside team-keys`); "
                                            "replaces --connect, --listen and --mode")


def bus_from_arguments(args: argparse.Namespace) -> BusConfig:
    bus = BusConfig(mode=args.mode, config_file=args.zenoh_config)
    if args.connect:
        bus.connect = list(args.connect)
    if args.listen:
        bus.listen = list(args.listen)
    return bus


def load_config_file(path: str | Path) -> zenoh.Config:
    """A Zenoh JSON5 config file; ValueError names the file and what is wrong with it."""
    if not Path(path).is_file():
        raise ValueError(f"Zenoh config file {path} does not exist")
    try:
        return zenoh.Config.from_file(str(path))
    except zenoh.ZError as exc:
        raise ValueError(f"Zenoh config file {path} is not valid: {exc}") from None


def env_endpoints() -> list[str]:
    """$PITCHSIDE_CONNECT: the router every process of this machine joins unless told otherwise."""
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
            where = bus.describe()
            log.warning("Zenoh router (%s) not reachable yet (%s); retrying", where, exc)
            time.sleep(0.5)


def router_settings(listen: list[str], connect: list[str] | None = None) -> dict[str, Any]:
    """A router's Zenoh config data: robots and dashboards connect to it by endpoint, nobody finds it by multicast."""
    return {"mode": "router", "listen": {"endpoints": list(listen)}, "connect": _connect_settings(connect or []),
            "scouting": {"multicast": {"enabled": False}}, "transport": link_settings()}


def router_config(listen: list[str] | None = None, connect: list[str] | None = None,
                  config_file: str | Path | None = None) -> zenoh.Config:
    """A router's Zenoh config; from a file (a team's router.json5: TLS, access control, endpoints), listen and
    connect, when given, replace the file's endpoints."""
    if config_file is None:
        conf = zenoh.Config.from_json5(json.dumps(router_settings(listen or [DEFAULT_LISTEN], connect)))
    else:
        conf = load_config_file(config_file)
        conf.insert_json5("mode", '"router"')
        if listen:
            conf.insert_json5("listen/endpoints", json.dumps(listen))
        if connect:
            conf.insert_json5("connect/endpoints", json.dumps(connect))
    if exposed := open_to_strangers(conf):
        log.warning("Zenoh router listening on %s without access control: anyone who reaches it may publish "
                    "motor_goals and cmd_vel to every robot; `pitchside team-keys` makes the team's secured bus "
                    "(docs/guides/secured-bus.md)", ", ".join(exposed))
    return conf


def open_to_strangers(conf: zenoh.Config) -> list[str]:
    """The endpoints a config listens on beyond loopback with no access control: others on the network may send."""
    if json.loads(conf.get_json("access_control/enabled")) is True:
        return []
    listen = json.loads(conf.get_json("listen/endpoints")) or []
    if isinstance(listen, dict):  # per mode: {"router": [...], "peer": [...]}
        listen = [e for endpoints in listen.values() for e in endpoints]
    return [e for e in listen if not is_loopback(endpoint_host(e) or "")]


def open_router(listen: list[str] | None = None, connect: list[str] | None = None,
                config_file: str | Path | None = None) -> zenoh.Session:
    """A Zenoh router inside this process: robots and dashboards connect to it by endpoint."""
    return zenoh.open(router_config(listen, connect, config_file))
