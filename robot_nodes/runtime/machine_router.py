"""The machine's Zenoh router, run inside the process that starts the machine's nodes (``pitchside robot``).

A robot is one machine: its router lets its nodes meet on loopback and is the robot's one link to the team
(``connect``: the laptop's router, in the lab). With nothing to connect to (a match) the robot's bus never
leaves the robot. If the router's port is taken on this machine (another router runs here), a free loopback
port is taken instead and said so.
"""

from __future__ import annotations

import logging
import socket
from dataclasses import dataclass

import zenoh

from robot_nodes.runtime.bus import DEFAULT_LISTEN, open_router
from robot_nodes.runtime.machine import endpoint_host, is_on_this_machine

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


def start_machine_router(listen: list[str] | None, connect: list[str]) -> MachineRouter:
    endpoints = list(listen or [DEFAULT_LISTEN])
    if not _port_free(endpoints[0]):
        taken = endpoints[0]
        endpoints[0] = _free_loopback_endpoint()
        log.warning("%s is taken on this machine (another router?); this machine's router listens on %s", taken,
                    endpoints[0])
    session = open_router(endpoints, connect)
    where = f", connecting to {', '.join(connect)}" if connect else " (connecting nowhere: the bus stays here)"
    log.info("this machine's Zenoh router listens on %s%s", ", ".join(endpoints), where)
    return MachineRouter(session, endpoints, list(connect))


def remote(endpoints: list[str]) -> list[str]:
    """The endpoints on other machines."""
    return [e for e in endpoints if not is_on_this_machine(e)]
