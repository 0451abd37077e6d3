"""A UDP port for what speaks to the world outside Zenoh (GameController and its simulator, team communication).

A reader thread only receives; with a node's loop it hands each datagram to the loop, where it is decoded, otherwise
it calls the handler itself. Sending happens on the caller's thread. The reader blocks until a datagram comes (an
idle port costs nothing); ``close`` wakes it by shutting the socket down.
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from robot_nodes.runtime.loop import EventLoop

Address = tuple[str, int]


class UdpPort:
    """Binds at once (OSError if it cannot); ``close`` stops the reader and the socket."""

    def __init__(self, host: str, port: int, on_datagram: Callable[[bytes, Address], None], *,
                 loop: EventLoop | None = None, recv_size: int = 65535, name: str = "udp",
                 reuse_address: bool = False) -> None:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        if reuse_address:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        with contextlib.suppress(OSError):  # broadcast is how GameControllers and teams often send
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
        try:
            sock.bind((host, port))
        except OSError:
            sock.close()
            raise
        self._sock = sock
        self._loop = loop
        self._on_datagram = on_datagram
        self._recv_size = recv_size
        self._stop = threading.Event()
        self._reader = threading.Thread(target=self._read, name=name, daemon=True)
        self._reader.start()

    @property
    def port(self) -> int:
        """The bound port (the one chosen when 0 was asked for)."""
        return int(self._sock.getsockname()[1])

    def sendto(self, data: bytes, address: Address) -> None:
        self._sock.sendto(data, address)

    def close(self) -> None:
        self._stop.set()
        with contextlib.suppress(OSError):  # an unconnected UDP socket says ENOTCONN, but its reader wakes
            self._sock.shutdown(socket.SHUT_RDWR)
        if self._reader is not threading.current_thread():
            self._reader.join(2.0)
        self._sock.close()

    def _read(self) -> None:
        while not self._stop.is_set():
            try:
                data, addr = self._sock.recvfrom(self._recv_size)
            except OSError:
                if self._stop.is_set():
                    return
                time.sleep(0.05)  # an ICMP error of an earlier send, a full buffer: read on
                continue
            if self._stop.is_set():
                return
            if self._loop is not None:
                self._loop.call_soon(self._on_datagram, data, addr)
            else:
                self._on_datagram(data, addr)
