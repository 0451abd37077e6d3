"""The UDP telemetry source: listens (never sends) for the robots' one-way telemetry datagrams and feeds the hub.

This is the only source that runs in match mode. Reassembly, loss counting and decoding belong to
``robot_nodes.telemetry.receiver.TelemetryReceiver``; this module only owns the socket and the hand-over.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from typing import Any

from server.hub import Hub, HubMessage
from server.sources import Source, SourceError

log = logging.getLogger(__name__)


def _load_receiver() -> Any:
    try:
        from robot_nodes.telemetry.receiver import TelemetryReceiver  # written by the telemetry engineer
    except ImportError as exc:
        raise SourceError(f"the telemetry receiver is not available: {exc}") from exc
    return TelemetryReceiver()


class _Listener(asyncio.DatagramProtocol):
    def __init__(self, source: TelemetrySource) -> None:
        self.source = source

    def datagram_received(self, data: bytes, addr: tuple[str | Any, int]) -> None:
        self.source.on_datagram(data, addr)

    def error_received(self, exc: Exception) -> None:
        self.source.error = str(exc)


class TelemetrySource(Source):
    """Binds a UDP socket; every datagram goes through the receiver, every complete message to the hub."""

    name = "telemetry"

    def __init__(self, hub: Hub, host: str, port: int) -> None:
        super().__init__()
        self.hub = hub
        self.host = host
        self.port = port
        self.datagrams = 0
        self.bad_datagrams = 0
        self.receiver: Any = None
        self._transport: asyncio.DatagramTransport | None = None

    async def start(self) -> None:
        self.receiver = _load_receiver()
        loop = asyncio.get_running_loop()
        try:
            transport, _ = await loop.create_datagram_endpoint(lambda: _Listener(self),
                                                               local_addr=(self.host, self.port))
        except OSError as exc:
            self.error = f"cannot listen for telemetry on {self.host}:{self.port}: {exc}"
            raise SourceError(self.error) from exc
        self._transport = transport  # type: ignore[assignment]
        self.port = transport.get_extra_info("sockname")[1]
        self.error = ""
        self.running = True

    async def stop(self) -> None:
        self.running = False
        transport, self._transport = self._transport, None
        if transport is not None:
            transport.close()

    def on_datagram(self, data: bytes, addr: tuple[Any, int]) -> None:
        """On the event loop: bad datagrams are counted, never raised."""
        self.datagrams += 1
        try:
            received = self.receiver.feed(data, addr)
        except Exception as exc:  # outside input: a broken datagram must not stop the listener
            self.bad_datagrams += 1
            self.error = f"bad datagram from {addr[0]}: {exc}"
            return
        for item in received:
            with contextlib.suppress(AttributeError, TypeError):
                self.hub.publish(_to_hub(item, self.name))

    def stream_health(self) -> dict[tuple[str, str], dict[str, Any]]:
        health = getattr(self.receiver, "stream_health", None)
        if health is None:
            return {}
        try:
            return dict(health())
        except Exception:  # figures are optional; never break the robots list
            return {}

    def status(self) -> dict[str, Any]:
        status = super().status()
        status.update(port=self.port, datagrams=self.datagrams, bad_datagrams=self.bad_datagrams)
        return status


def _to_hub(item: Any, source: str) -> HubMessage:
    """TODO(telemetry): adapt to the receiver's message type once robot_nodes/telemetry/receiver.py exists."""
    data = getattr(item, "msg", None) or getattr(item, "payload", None)
    return HubMessage(item.robot_id, item.topic, item.typename, getattr(item, "stamp", None) or time.time(), data,
                      source)
