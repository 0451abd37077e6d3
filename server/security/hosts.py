"""Which names the dashboard answers to in the ``Host`` header: the defence against DNS rebinding.

A web page on evil.example can make its own name resolve to 127.0.0.1; the browser then sends the dashboard
requests with ``Host: evil.example``. Answering only the names the server is really reached by (loopback
names, this machine's own addresses when it listens beyond loopback, names given by flag) refuses them all.
"""

from __future__ import annotations

import ipaddress
import time

from wire.machine import is_loopback, machine_addresses, machine_names

LOOPBACK_NAMES = frozenset({"localhost", "127.0.0.1", "::1"})
_ADDRESSES_TTL_S = 5.0  # the laptop may get a new address from the venue's Wi-Fi while the server runs


def host_name_of(host_header: str) -> str | None:
    """The lower-case name (or address) of a Host header without port or brackets; None if malformed."""
    host = host_header.strip().lower()
    if not host or any(c.isspace() or c in "/\\@?#" for c in host):
        return None
    if host.startswith("["):  # [::1]:8080
        end = host.find("]")
        if end < 0 or (host[end + 1:] and not (host[end + 1] == ":" and host[end + 2:].isdigit())):
            return None
        return host[1:end] or None
    name, sep, port = host.rpartition(":")
    if sep and port.isdigit() and ":" not in name:
        host = name
    elif ":" in host and not _is_address(host):
        return None
    return host.rstrip(".") or None


def _is_address(text: str) -> bool:
    try:
        ipaddress.ip_address(text)
    except ValueError:
        return False
    return True


class AllowedHosts:
    """The Host names one server answers to, decided from where it listens and the names given by flag."""

    def __init__(self, bind_host: str, extra: list[str] | tuple[str, ...] = ()) -> None:
        self.bind_host = bind_host.strip("[]").lower()
        self.extra = {n.strip().lower().rstrip(".") for n in extra if n.strip()}
        self.beyond_loopback = not is_loopback(self.bind_host)
        self.all_interfaces = self.bind_host in ("0.0.0.0", "::", "")
        self._names = machine_names() if self.beyond_loopback else set()
        self._addresses: set[str] = set()
        self._addresses_at = -_ADDRESSES_TTL_S

    def allows(self, name: str | None) -> bool:
        if name is None:
            return False
        if is_loopback(name) or name in self.extra:
            return True
        if not self.beyond_loopback:
            return False
        if name == self.bind_host or name in self._names:
            return True
        return self.all_interfaces and _is_address(name) and name in self._current_addresses()

    def _current_addresses(self) -> set[str]:
        now = time.monotonic()
        if now - self._addresses_at > _ADDRESSES_TTL_S:
            self._addresses, self._addresses_at = machine_addresses(), now
        return self._addresses

    def describe(self) -> str:
        shown = sorted(LOOPBACK_NAMES | self.extra | ({self.bind_host} if self.beyond_loopback else set()))
        if self.all_interfaces:
            shown.append("this machine's addresses and names")
        return ", ".join(shown)
