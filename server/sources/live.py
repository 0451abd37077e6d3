"""The live Zenoh source: joins the team's Zenoh network and feeds every ROS 2 topic of the listened domains to the
hub.

Only subscribes (``<domain>/**`` per domain: rmw_zenoh's data keys); never started in match mode, since even a
Zenoh subscriber sends declarations to the robots it is connected to. Where each key's samples go (robot, topic,
type, a translation onto a panel's type) is server.profiles.routes' decision; which robots exist, the liveliness
tokens' (server.sources.ros2_robots).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
from collections import Counter, deque
from typing import Any

import zenoh
import zenoh.ext

import schemas
from schemas.interface_folder import InterfaceFolderError, register_interfaces
from server.hub import Hub, HubMessage
from server.profiles.images import CONVERTERS
from server.profiles.routes import ROSOUT, Refusal, Route, RouteRefused, route
from server.profiles.team import Ros2Setup
from server.profiles.translate import translate
from server.sources import Source, SourceError
from server.sources.ros2_robots import Ros2Robots
from server.sources.stamps import stamp_of
from server.zenoh_link import ZenohLink
from wire import keys
from wire.ros2.robots import robot_of_logger

log = logging.getLogger(__name__)

# Samples waiting for the event loop, bounded by count and by payload bytes; beyond either, the oldest go (the loop
# is overloaded). By bytes too: 50 000 camera images of 20 KB would be a gigabyte; 32 MB is 10 s of 11 robots'
# cameras at 10 Hz and 30 KB, or 0.8 s of a 40 MB/s flood.
MAX_PENDING = 50_000
MAX_PENDING_BYTES = 32 << 20
MAX_ROUTES = 4096  # routes kept per key (a bus has few keys; a flood of made-up keys only empties the cache)
BAD_NAMES = (Refusal.BAD_KEY, Refusal.BAD_NAME)
# normal on a ROS 2 bus (/parameter_events, /clock of the root namespace; an action's hidden topics): counted only
QUIET = (Refusal.NO_ROBOT, Refusal.HIDDEN)


def subscribe_keys(setup: Ros2Setup) -> list[str]:
    """Every topic of every listened domain: rmw_zenoh's data keys start with the domain id."""
    return [f"{domain}/**" for domain in setup.listened()]


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


def robot_of_log(message: Any) -> str:
    """The robot of a record on the global /rosout: its logger's first part (node /robot1/hcm logs as robot1.hcm)."""
    robot = robot_of_logger(str(getattr(message, "name", "")))
    return robot if robot is not None and keys.is_valid_name(robot) else ""


class LiveZenohSource(Source):
    """Zenoh callbacks append to a pending batch; the event loop drains it in one go."""

    name = "live"

    def __init__(self, hub: Hub, link: ZenohLink, setup: Ros2Setup | None = None) -> None:
        super().__init__()
        self.hub = hub
        self.link = link
        self.setup = setup or Ros2Setup()
        self.robots: Ros2Robots | None = None  # the robots the liveliness tokens show, while running
        self.received = 0
        self._pending = PendingSamples()  # guarded by _lock
        self.bad_names = 0  # messages whose key, robot id or topic breaks the naming rules
        self.refused: Counter[str] = Counter()  # messages refused, by reason (Refusal.name)
        self.missing: set[str] = set()  # types heard whose definition pitchside does not have
        self.undecodable = 0  # payloads that do not decode as their key's type
        self.interfaces: list[str] = []  # types loaded from the team's interface folder
        self._routes: dict[str, Route | RouteRefused] = {}
        self._warned: set[tuple[str, str]] = set()  # (reason, key) logged once
        self._lock = threading.Lock()
        self._scheduled = False
        self._subs: list[Any] = []
        self._loop: asyncio.AbstractEventLoop | None = None

    async def start(self) -> None:
        if self.link.match_mode:
            raise SourceError("the live Zenoh source cannot run in match mode: even a Zenoh subscriber sends "
                              "declarations to the robots")
        self._loop = asyncio.get_running_loop()
        if self.setup.interfaces is not None and not self.interfaces:
            try:
                self.interfaces = await asyncio.to_thread(register_interfaces, self.setup.interfaces)
            except InterfaceFolderError as exc:
                self.error = f"cannot load the team's interface definitions: {exc}"
                raise SourceError(self.error) from exc
        try:
            session = await asyncio.to_thread(self.link.session)
            self.robots = await asyncio.to_thread(Ros2Robots, session, self.setup)
            # running before the first sample can be drained: the latched ones come at once (the drain, on this
            # loop, may run while the subscribers are being declared)
            self.running = True
            # an advanced subscriber with history: latched topics (robot_description, tf_static; rmw_zenoh's
            # transient local publishers keep them in a zenoh-ext cache) reach a dashboard started after the robot
            self._subs = await asyncio.to_thread(self._subscribe, session)
        except zenoh.ZError as exc:
            await self.stop()
            self.error = f"cannot join the Zenoh network: {exc}"
            raise SourceError(self.error) from exc
        self.error = ""

    def _subscribe(self, session: zenoh.Session) -> list[Any]:
        return [zenoh.ext.declare_advanced_subscriber(
            session, key, self._on_sample, history=zenoh.ext.HistoryConfig(detect_late_publishers=True))
            for key in subscribe_keys(self.setup)]

    async def stop(self) -> None:
        self.running = False
        subs, self._subs = self._subs, []
        for sub in subs:
            with contextlib.suppress(zenoh.ZError):
                sub.undeclare()
        robots, self.robots = self.robots, None
        if robots is not None:
            with contextlib.suppress(zenoh.ZError):
                robots.close()

    def _on_sample(self, sample: zenoh.Sample) -> None:
        """On a Zenoh thread: keep it short."""
        stamp = sample.timestamp  # the publisher's clock (every pitchside session stamps what it puts)
        sent = stamp.get_time().timestamp() if stamp is not None else None
        item = (str(sample.key_expr), sample.payload.to_bytes(), str(sample.encoding), sent)
        with self._lock:
            self._pending.append(item)
            wake = not self._scheduled
            self._scheduled = True
        if wake and self._loop is not None:
            with contextlib.suppress(RuntimeError):  # loop closed while shutting down
                self._loop.call_soon_threadsafe(self._drain)

    def route_of(self, key: str) -> Route | RouteRefused:
        found = self._routes.get(key)
        if found is None:
            if len(self._routes) >= MAX_ROUTES:
                self._routes.clear()
            try:
                found = route(key, self.setup)
            except RouteRefused as exc:
                found = exc
            self._routes[key] = found
        return found

    def _refuse(self, key: str, refusal: RouteRefused) -> None:
        self.refused[refusal.reason.name] += 1
        if refusal.reason in BAD_NAMES:
            self.bad_names += 1  # a name that breaks the rules never reaches the hub (or a page)
            if self.bad_names in (1, 10, 100, 1000) or self.bad_names % 10000 == 0:
                log.warning("live: dropped %d messages with bad names, latest: %s", self.bad_names, refusal)
            return
        if refusal.reason in QUIET:
            return
        if refusal.reason is Refusal.DEFINITION_MISSING and refusal.key is not None:
            self.missing.add(refusal.key.ros_type)
        self._warn_once(refusal.reason.name, key, str(refusal))

    def _warn_once(self, reason: str, key: str, text: str) -> None:
        if (reason, key) not in self._warned and len(self._warned) < MAX_ROUTES:
            self._warned.add((reason, key))
            log.warning("live: %s (%s; further ones counted)", text, key)

    def _drain(self) -> None:
        with self._lock:
            batch = self._pending.take()
            self._scheduled = False
        if not self.running:
            return
        for key, payload, _encoding, sent in batch:
            found = self.route_of(key)
            if isinstance(found, RouteRefused):
                self._refuse(key, found)
                continue
            if found.table and found.robot:  # a pitchside robot's topic: decoded when a consumer first needs it
                self.received += 1
                self.hub.publish(HubMessage(found.robot, found.topic, found.typename, stamp_of(payload, found.typename),
                                            payload, self.name, sent=sent))
                continue
            message = self._decoded(key, payload, found, sent)
            if message is None:
                continue
            self.received += 1
            self.hub.publish(message)

    def _decoded(self, key: str, payload: bytes, found: Route, sent: float | None) -> HubMessage | None:
        """Another robot's sample, decoded here (a payload that does not decode is counted, never shown)."""
        try:
            wire_message = schemas.decode(payload, found.wire_type)
            robot = found.robot or robot_of_log(wire_message)
            if not robot:
                self._refuse(key, RouteRefused(Refusal.NO_ROBOT, f"a {ROSOUT} record of no robot's node"))
                return None
            stamp = stamp_of(payload, found.wire_type)
            converter = CONVERTERS.get((found.wire_type, found.typename))
            if converter is not None:  # a raw image as the camera panel's JPEG
                return HubMessage(robot, found.topic, found.typename, stamp, converter(wire_message), self.name,
                                  sent=sent)
            if found.mapping is None:
                return HubMessage(robot, found.topic, found.typename, stamp, payload, self.name, sent=sent,
                                  decoded=wire_message)
            return HubMessage(robot, found.topic, found.typename, stamp, translate(found.mapping, wire_message),
                              self.name, sent=sent)
        except Exception as exc:  # rosbags raises several kinds on garbage; a bad value must not stop the loop
            self.undecodable += 1
            self._warn_once("UNDECODABLE", key, f"a payload that does not decode as {found.wire_type}: {exc}")
            return None

    def status(self) -> dict[str, Any]:
        status = super().status()
        status.update(received=self.received, unknown_topics=sum(self.refused.values()) - self.bad_names,
                      bad_names=self.bad_names, refused=dict(self.refused), definitions_missing=sorted(self.missing),
                      undecodable=self.undecodable, domains=list(self.setup.listened()),
                      profile=self.setup.profile.name, interfaces_loaded=len(self.interfaces),
                      overflow=self._pending.dropped, zenoh_open=self.link.is_open)
        return status
