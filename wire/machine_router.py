"""The machine's Zenoh router, run inside the process that starts the machine's nodes (``pitchside robot``).

A robot is one machine: its router lets its nodes meet on loopback and is the robot's one link to the team
(``connect``: the laptop's router, in the lab). With nothing to connect to (a match) the robot's bus never
leaves the robot. If the router's port is taken on this machine (another router runs here), a free loopback
port is taken instead and said so.

On a team's secured bus the router takes the robot's file from ``pitchside team-keys`` (mutual TLS to the team
router, the access control): the nodes still join it in plain TCP on loopback, so such a router refuses to
listen beyond loopback without TLS.
"""

from __future__ import annotations

import json
import logging
import socket
from dataclasses import dataclass
from pathlib import Path

import zenoh

from wire.bus import DEFAULT_LISTEN, load_config_file, router_config
from wire.machine import endpoint_host, is_loopback, is_on_this_machine

log = logging.getLogger("pitchside.router")


@dataclass(slots=True)
class MachineRouter:
    session: zenoh.Session
    listen: list[str]
    connect: list[str]

    @property
    def local_endpoint(self) -> str:
        """Where the machine's processes reach it: its first listen endpoint, on loopback."""
        protocol, _, address = self.listen[0].partition("/")
        port = address.rsplit(":", 1)[1]
        return f"{protocol}/127.0.0.1:{port}"

    def close(self) -> None:
        self.session.close()


def _port_free(endpoint: str) -> bool:
    host = endpoint_host(endpoint) or "127.0.0.1"
    port = int(endpoint.rsplit(":", 1)[1])
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET) as probe:
        try:
            probe.bind((host, port))
        except OSError:
            return False
    return True


def _free_loopback_endpoint() -> str:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{probe.getsockname()[1]}"


def _endpoints(conf: zenoh.Config, key: str) -> list[str]:
    return [str(e) for e in json.loads(conf.get_json(key)) or []]


def is_secured(conf: zenoh.Config) -> bool:
    """True for a config with Zenoh's access control on (a team's file)."""
    return json.loads(conf.get_json("access_control/enabled")) is True


def is_router_config(config_file: str | Path) -> bool:
    """True for a Zenoh config file of a router (a robot's file from `pitchside team-keys`); ValueError if it
    cannot be read."""
    return json.loads(load_config_file(config_file).get_json("mode")) == "router"


def start_machine_router(listen: list[str] | None, connect: list[str] | None,
                         config_file: str | Path | None = None) -> MachineRouter:
    """This machine's router. listen and connect, when given, replace the config file's endpoints; connect None
    keeps the file's, [] connects nowhere (a robot in a match). ValueError for a config it will not run."""
    conf = router_config(listen, connect, config_file)
    if connect is not None and not connect:
        conf.insert_json5("connect/endpoints", "[]")
    endpoints = _endpoints(conf, "listen/endpoints") or [DEFAULT_LISTEN]
    if not _port_free(endpoints[0]):
        taken = endpoints[0]
        protocol = taken.partition("/")[0]
        endpoints[0] = protocol + _free_loopback_endpoint().removeprefix("tcp")
        log.warning("%s is taken on this machine (another router?); this machine's router listens on %s", taken,
                    endpoints[0])
    conf.insert_json5("listen/endpoints", json.dumps(endpoints))
    secured = is_secured(conf)
    if secured:
        # the robot's nodes join in plain TCP: anything but TLS beyond loopback would let the network in
        exposed = [e for e in endpoints if e.partition("/")[0] != "tls" and not is_loopback(endpoint_host(e) or "")]
        if exposed:
            raise ValueError(f"a router with a team's access control listens beyond loopback only with TLS, not on "
                             f"{', '.join(exposed)}")
    targets = _endpoints(conf, "connect/endpoints")
    try:
        session = zenoh.open(conf)
    except zenoh.ZError as exc:
        raise ValueError(f"this machine's Zenoh router did not start: {exc}") from None
    where = f", connecting to {', '.join(targets)}" if targets else " (connecting nowhere: the bus stays here)"
    how = f" ({config_file}, access control on)" if secured else f" ({config_file})" if config_file else ""
    log.info("this machine's Zenoh router listens on %s%s%s", ", ".join(endpoints), where, how)
    return MachineRouter(session, endpoints, targets)


def remote(endpoints: list[str]) -> list[str]:
    """The endpoints on other machines."""
    return [e for e in endpoints if not is_on_this_machine(e)]
