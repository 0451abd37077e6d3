"""This machine on the network: its addresses and names, and whether an endpoint points at it.

Which Zenoh mode a process takes, and whether the dashboard answers a Host name, both depend on it.
"""

from __future__ import annotations

import ipaddress
import socket


def machine_addresses() -> set[str]:
    """Every address of this machine's interfaces (IPv4 and IPv6, without zone ids), loopback included."""
    import psutil

    found = set()
    for addresses in psutil.net_if_addrs().values():
        for address in addresses:
            if address.family in (socket.AF_INET, socket.AF_INET6):
                found.add(address.address.split("%", 1)[0].lower())
    return found


def machine_names() -> set[str]:
    names = {socket.gethostname().lower(), socket.getfqdn().lower()}
    return names | {f"{n.split('.', 1)[0]}.local" for n in names if n}


def is_loopback(host: str) -> bool:
    if host in ("localhost",) or host.endswith(".localhost"):
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def endpoint_host(endpoint: str) -> str | None:
    """The host of a Zenoh endpoint (``tcp/10.0.0.5:7447``, ``tls/[::1]:7447#iface=eth0``), None if it has none."""
    _, sep, address = endpoint.partition("/")
    if not sep:
        return None
    address = address.split("#", 1)[0].split("?", 1)[0]
    if address.startswith("["):
        return address[1:address.find("]")].lower() or None
    host, sep, _ = address.rpartition(":")
    return (host if sep else address).lower() or None


def is_on_this_machine(endpoint: str) -> bool:
    """True if the endpoint's host is this machine (loopback, one of its addresses, or its own name)."""
    host = endpoint_host(endpoint)
    if host is None:
        return False
    if is_loopback(host) or host in machine_names() or host in ("0.0.0.0", "::"):
        return True
    try:
        resolved = {str(info[4][0]).split("%", 1)[0].lower() for info in socket.getaddrinfo(host, None)}
    except OSError:
        return False
    return bool(resolved & machine_addresses())
