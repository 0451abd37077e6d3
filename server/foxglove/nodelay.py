"""TCP_NODELAY on the connections the Foxglove SDK accepts (from the guard), which foxglove-sdk 0.30 leaves off.

With Nagle's algorithm on, the SDK holds back a small write until the other end acknowledges the previous one,
and acknowledgements are delayed: bench/foxglove.py measured 10 ms p50 from hub to client with the demo's message
mix, 0.6 ms with TCP_NODELAY. The SDK offers no option for it, so when the guard passes a connection on, the
endpoint looks at this process's new sockets and sets the option on those accepted on the SDK's port. Socket
options belong to the socket, not the file descriptor, so setting it through a duplicate descriptor is enough.
Remove this module once the SDK sets the option itself.
"""

from __future__ import annotations

import contextlib
import os
import socket
from pathlib import Path

FDS = Path("/proc/self/fd")


class NoDelayWatch:
    """Sets TCP_NODELAY on connections accepted on ``ports`` by this process, once each."""

    def __init__(self, ports: set[int]) -> None:
        self.ports = ports  # the caller may change it: the SDK's servers are replaced when a replay opens
        self.known: set[str] = set()  # sockets looked at ("socket:[inode]"), ours or not: each is looked at once
        self.looks = 0  # times /proc was read
        self.applied = 0  # connections that got the option

    def apply(self) -> int:
        """Looks once at this process's new sockets; returns how many got the option now."""
        applied = 0
        self.looks += 1
        current = set()
        for name in os.listdir(FDS):
            with contextlib.suppress(OSError):  # closed meanwhile
                target = os.readlink(FDS / name)
                if not target.startswith("socket:"):
                    continue
                current.add(target)
                if target in self.known:
                    continue
                self.known.add(target)
                applied += self._set(int(name))
        self.known &= current
        self.applied += applied
        return applied

    def _set(self, fd: int) -> int:
        copy = os.dup(fd)
        try:
            dup = socket.socket(fileno=copy)
        except (OSError, ValueError):  # a socket family Python does not know (netlink, ...): not ours
            os.close(copy)
            return 0
        with dup:
            if dup.type != socket.SOCK_STREAM or dup.family not in (socket.AF_INET, socket.AF_INET6):
                return 0
            if dup.getsockname()[1] not in self.ports:
                return 0
            try:
                dup.getpeername()  # an accepted connection, not the listening socket
            except OSError:
                return 0
            dup.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            return 1
