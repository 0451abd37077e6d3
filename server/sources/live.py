"""The live Zenoh source: joins the team's Zenoh network and feeds every topic message to the hub.

Only subscribes (``<domain>/*/**``: the topics of every robot namespace and of the root namespace, such as
/rosout, whose robot the message names; rmw_zenoh's data keys); never started
in match mode, since even a Zenoh subscriber sends declarations to the robots it is connected to.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
from collections import deque
from typing import Any

import zenoh

import schemas
from server.hub import Hub, HubMessage
from server.sources import Source, SourceError
from server.sources.stamps import stamp_of
from server.zenoh_link import ZenohLink
from wire import keys

log = logging.getLogger(__name__)

def subscribe_key() -> str:
    """Every topic of every robot of the domain (ROS_DOMAIN_ID when the source starts)."""
    return keys.all_topics_key()
# Samples waiting for the event loop, bounded by count and by payload bytes; beyond either, the oldest go (the loop
# is overloaded). By bytes too: 50 000 camera images of 20 KB would be a gigabyte; 32 MB is 10 s of 11 robots'
# cameras at 10 Hz and 30 KB, or 0.8 s of a 40 MB/s flood.
MAX_PENDING = 50_000
MAX_PENDING_BYTES = 32 << 20


class PendingSamples:
    """What Zenoh's threads have handed over and the event loop has not taken yet: the newest, within both bounds."""

    def __init__(self, max_count: int = MAX_PENDING, max_bytes: int = MAX_PENDING_BYTES) -> None:
        self.max_count = max_count
        self.max_bytes = max_bytes
        self.dropped = 0
        self.bytes = 0
        self._items: deque[tuple[str, bytes, str, float | None]] = deque()

    def __len__(self) -> int:
        return len(self._items)

    def append(self, item: tuple[str, bytes, str, float | None]) -> None:
        self._items.append(item)
        self.bytes += len(item[1])
        while len(self._items) > self.max_count or (self.bytes > self.max_bytes and len(self._items) > 1):
            self.bytes -= len(self._items.popleft()[1])
            self.dropped += 1

    def take(self) -> list[tuple[str, bytes, str, float | None]]:
        """Everything waiting, oldest first; empty afterwards."""
        items = list(self._items)
        self._items.clear()
        self.bytes = 0
        return items


def typename_of(topic: str, encoding: str) -> str | None:
    """The topic table's type, else the schema named by the Zenoh encoding ("application/cdr;pkg/msg/Type")."""
    entry = schemas.TOPICS.get(topic)
    if entry is not None:
        return entry.type
    _, sep, schema = encoding.partition(";")
    if sep and schema:
        try:
            return schemas.codec.full_name(schema)
        except schemas.SchemaError:
            return None
    return None


class LiveZenohSource(Source):
    """Zenoh callbacks append to a pending batch; the event loop drains it in one go."""

    name = "live"

    def __init__(self, hub: Hub, link: ZenohLink) -> None:
        super().__init__()
        self.hub = hub
        self.link = link
        self.received = 0
        self.unknown = 0
        self._pending = PendingSamples()  # guarded by _lock
        self.bad_names = 0  # messages whose robot id or topic breaks the naming rules
        self.unattributed = 0  # messages of the root namespace that are no robot's (/clock)
        self._lock = threading.Lock()
        self._scheduled = False
        self._sub: zenoh.Subscriber | None = None
        self._loop: asyncio.AbstractEventLoop | None = None

    async def start(self) -> None:
        if self.link.match_mode:
            raise SourceError("the live Zenoh source cannot run in match mode: even a Zenoh subscriber sends "
                              "declarations to the robots")
        self._loop = asyncio.get_running_loop()
        try:
            session = await asyncio.to_thread(self.link.session)
            self._sub = session.declare_subscriber(subscribe_key(), self._on_sample)
        except zenoh.ZError as exc:
            self.error = f"cannot join the Zenoh network: {exc}"
            raise SourceError(self.error) from exc
        self.error = ""
        self.running = True

    async def stop(self) -> None:
        self.running = False
        sub, self._sub = self._sub, None
        if sub is not None:
            with contextlib.suppress(zenoh.ZError):
                sub.undeclare()

    def _on_sample(self, sample: zenoh.Sample) -> None:
        """On a Zenoh thread: keep it short."""
        key = str(sample.key_expr)
        if not keys.is_topic_key(key):
            return
        stamp = sample.timestamp  # the publisher's clock (every pitchside session stamps what it puts)
        sent = stamp.get_time().timestamp() if stamp is not None else None
        item = (key, sample.payload.to_bytes(), str(sample.encoding), sent)
        with self._lock:
            self._pending.append(item)
            wake = not self._scheduled
            self._scheduled = True
        if wake and self._loop is not None:
            with contextlib.suppress(RuntimeError):  # loop closed while shutting down
                self._loop.call_soon_threadsafe(self._drain)

    def _drain(self) -> None:
        with self._lock:
            batch = self._pending.take()
            self._scheduled = False
        if not self.running:
            return
        for key, payload, encoding, sent in batch:
            try:
                robot, topic = keys.split_sample(key, payload)  # /rosout: the robot from the logger name
            except keys.NoRobotsMessage:  # /clock, a record of a ROS 2 node outside every robot's namespace
                self.unattributed += 1
                continue
            except ValueError as exc:  # a name that breaks the rules never reaches the hub (or a page)
                self.bad_names += 1
                if self.bad_names in (1, 10, 100, 1000) or self.bad_names % 10000 == 0:
                    log.warning("live: dropped %d messages with bad names, latest: %s", self.bad_names, exc)
                continue
            typename = typename_of(topic, encoding)
            if typename is None:
                self.unknown += 1
                continue
            self.received += 1
            self.hub.publish(HubMessage(robot, topic, typename, stamp_of(payload, typename), payload, self.name,
                                        sent=sent))

    def status(self) -> dict[str, Any]:
        status = super().status()
        status.update(received=self.received, unknown_topics=self.unknown, bad_names=self.bad_names,
                      unattributed=self.unattributed,
                      overflow=self._pending.dropped,
                      zenoh_open=self.link.is_open)
        return status
