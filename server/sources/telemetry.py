"""The UDP telemetry source: listens (never sends) for the robots' one-way telemetry and feeds the hub.

The only source that runs in match mode. Authentication, reassembly, loss counting and decoding belong to
``wire.telemetry.receiver.TelemetryReceiver``; this module owns the listening socket and the hand-over.
Besides the robots' chosen topics, each robot's compact overview datagram arrives as topic ``overview`` (type
``pitchside_msgs/msg/RobotOverview``, a row of the topic table like every other), enough for the team overview.
"""

from __future__ import annotations

import asyncio
import logging
import time
from typing import Any

from server.hub import Hub, HubMessage
from server.sources import Source, SourceError
from server.sources.stamps import stamp_of, starts_with_header

log = logging.getLogger(__name__)
# a stream that arrived over live Zenoh this recently is not taken again from telemetry
LIVE_WINS_S = 1.0


class TelemetrySource(Source):
    """Binds a UDP socket; every datagram goes through the receiver, every whole message to the hub."""

    name = "telemetry"

    def __init__(self, hub: Hub, host: str, port: int, key: str | None = None) -> None:
        super().__init__()
        self.hub = hub
        self.host = host
        self.port = port
        self.key = key
        self.messages = 0
        self.undecodable = 0
        self.shadowed = 0
        self.receiver: Any = None
        self._transport: asyncio.DatagramTransport | None = None

    async def start(self) -> None:
        try:
            from wire.telemetry.receiver import TelemetryReceiver, listen
        except ImportError as exc:
            raise SourceError(f"the telemetry receiver is not available: {exc}") from exc
        if self.receiver is None:
            # messages go to the hub as the CDR they came in: decoded only if a panel, a plot or the team overview
            # wants them, passed on as they are to recordings and Foxglove
            self.receiver = TelemetryReceiver(self.key, decode=False)
        try:
            self._transport = await listen(self.receiver, self._on_messages, host=self.host, port=self.port)
        except OSError as exc:
            self.error = f"cannot listen for telemetry on {self.host}:{self.port}: {exc}"
            raise SourceError(self.error) from exc
        self.port = self._transport.get_extra_info("sockname")[1]
        self.error = ""
        self.running = True

    async def stop(self) -> None:
        self.running = False
        transport, self._transport = self._transport, None
        if transport is not None:
            transport.close()

    def _on_messages(self, received: list[Any]) -> None:
        """On the event loop, with the messages one datagram completed."""
        now = time.monotonic()
        for item in received:
            latest = self.hub.latest.get((item.robot_id, item.topic))
            if latest is not None and latest.source == "live" and now - latest.received < LIVE_WINS_S:
                # in the lab a robot's stream arrives twice; the live copy is complete, so the telemetry
                # copy only counts for link health (the receiver has counted it already)
                self.shadowed += 1
                continue
            if item.error:  # the receiver counted why (a schema this server does not have)
                self.undecodable += 1
                continue
            self.messages += 1
            stamp = stamp_of(item.payload, item.type) if starts_with_header(item.type) else item.send_time
            data = item.msg if item.msg is not None else item.payload  # the overview comes decoded
            self.hub.publish(HubMessage(item.robot_id, item.topic, item.type, stamp, data, self.name,
                                        sent=item.send_time))

    def stream_health(self) -> dict[tuple[str, str], dict[str, Any]]:
        if self.receiver is None:
            return {}
        out = {}
        for robot, health in self.receiver.health().items():
            for stream in health.streams:
                out[(robot, stream.topic)] = {"loss_pct": stream.loss_pct,
                                              "budget_share": round(stream.budget_share, 4),
                                              "link_rate_hz": round(stream.rate_hz, 2)}
        return out

    def status(self) -> dict[str, Any]:
        status = super().status()
        status.update(port=self.port, messages=self.messages, undecodable=self.undecodable, shadowed=self.shadowed)
        if self.receiver is not None:
            status.update(self.receiver.counters())
        return status
