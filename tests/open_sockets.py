"""What a process listens on, as `ss -lunt` would say it, read from /proc: the socket inodes among its open files
(/proc/<pid>/fd) found in the tables of its own network namespace (/proc/<pid>/net/{tcp,tcp6,udp,udp6}).

TCP sockets count when they listen; UDP sockets always (anything bound can be sent to). Works for processes in
another network namespace, where psutil (which reads this process's /proc/net) finds nothing.
"""

from __future__ import annotations

import ipaddress
import os
from dataclasses import dataclass
from pathlib import Path

_TCP_LISTEN = "0A"


@dataclass(frozen=True, order=True)
class OpenSocket:
    protocol: str  # "TCP" or "UDP"
    address: str  # "127.0.0.1", "0.0.0.0", "::"
    port: int


def _address(hex_address: str) -> tuple[str, int]:
    host, port = hex_address.split(":")
    raw = bytes.fromhex(host)
    # the kernel prints each 32-bit word in host order (little-endian here)
    words = b"".join(raw[i:i + 4][::-1] for i in range(0, len(raw), 4))
    return str(ipaddress.ip_address(words)), int(port, 16)


def _inodes(pid: int) -> set[str]:
    found = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            target = os.readlink(fd)
        except OSError:  # closed meanwhile
            continue
        if target.startswith("socket:["):
            found.add(target[8:-1])
    return found


def open_sockets(pid: int) -> set[OpenSocket]:
    """The listening TCP and bound UDP sockets of one process; empty once it is gone."""
    try:
        inodes = _inodes(pid)
        tables = {name: Path(f"/proc/{pid}/net/{name}").read_text().splitlines()[1:]
                  for name in ("tcp", "tcp6", "udp", "udp6")}
    except (FileNotFoundError, ProcessLookupError):
        return set()
    out = set()
    for name, lines in tables.items():
        for line in lines:
            fields = line.split()
            if fields[9] not in inodes or (name.startswith("tcp") and fields[3] != _TCP_LISTEN):
                continue
            address, port = _address(fields[1])
            out.add(OpenSocket(name[:3].upper(), address, port))
    return out
