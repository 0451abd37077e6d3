"""Every (robot, topic) stream of the hub as a Foxglove channel ``/<robot>/<topic>``: ros2msg schema, CDR bytes.

A channel opens with its stream's first message and closes when the stream ends (its source stopped, or its robot
is lost). The channels read the hub through one bounded hub subscriber, like a browser does: if handing messages
to the SDK falls behind, the hub drops this subscriber's oldest messages and never waits for it. The SDK then
keeps a bounded queue per Foxglove client (``message_backlog_size``), so a client that does not read loses its
oldest messages too, and nobody else notices.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Protocol

import foxglove

import schemas
from server.hub import Hub, HubMessage, RobotSeen, StreamStats

log = logging.getLogger(__name__)
SCHEMA_ENCODING = "ros2msg"  # what pitchside's MCAP recordings carry (schemas.logs.writer)
MESSAGE_ENCODING = "cdr"
QUEUE = 4000  # messages the hub may hold for the endpoint before it drops the oldest (2 s of 11 robots)
DRAIN_BATCH = 512
SWEEP_PERIOD_S = 1.0  # how often ended streams are looked for
REPLAY_SOURCE = "replay"  # its streams pause with the replay and stay until the replay source stops


def channel_topic(robot: str, topic: str) -> str:
    """The Foxglove topic of a hub stream: ``/robot1/joint_states``, ``/robot1/camera/image/compressed``."""
    return f"/{robot}/{topic}"


def stream_ended(robot: RobotSeen, stats: StreamStats, now: float, lost_after_s: float,
                 source_running: Callable[[str], bool | None]) -> bool:
    """A stream's channel closes when its source was switched off, or, outside replay, its robot is lost (the
    dashboard's rule: nothing from the robot for ``lost_after_s``). Streams that publish only on change (robot_state,
    gamestate) stay while their robot sends anything at all."""
    if source_running(stats.source) is False:
        return True
    return stats.source != REPLAY_SOURCE and now - robot.last_received >= lost_after_s


class DerivedChannels(Protocol):
    """Channels computed from some hub streams (camera annotations, the 3D scene's /tf and markers)."""

    topics: frozenset[str]  # the hub topics it is offered
    names: frozenset[str]  # the topic names of its own channels (``/<robot>/<name>``): see ``owns``

    @property
    def channels(self) -> Mapping[str, object]:
        """Robot -> its channel(s); closed with the robot's streams."""

    def offer(self, msg: HubMessage) -> None: ...

    def owns(self, msg: HubMessage) -> bool:
        """Is the stream's channel name one it makes itself? Then the stream gets no channel."""

    def close_robot(self, robot: str) -> None: ...

    def close(self) -> None: ...


@dataclass(slots=True)
class StreamChannel:
    """The SDK channel of one hub stream, and what it carries."""

    channel: foxglove.Channel
    typename: str
    messages: int = 0


class StreamChannels:
    """Opens, feeds and closes one SDK channel per hub stream; runs as a task on the hub's event loop."""

    def __init__(self, hub: Hub, context: foxglove.Context, lost_after_s: float,
                 source_running: Callable[[str], bool | None], derived: list[DerivedChannels] | None = None) -> None:
        self.hub = hub
        self.derived = derived or []
        self.shows: Callable[[HubMessage], bool] = lambda _msg: True  # which streams the endpoint serves now
        self._derived_names = frozenset().union(*(d.names for d in self.derived))
        self.newest_stamp = 0.0  # of the messages handed over: a replay's position in the log
        self.context = context
        self.lost_after_s = lost_after_s
        self.source_running = source_running
        self.channels: dict[tuple[str, str], StreamChannel] = {}
        self.unschematized: set[str] = set()  # types without a definition: their streams get no channel
        self.logged = 0  # messages handed to the SDK (with at least one client subscribed)
        self.encode_errors = 0
        self._task: asyncio.Task[None] | None = None
        self._stopping = False
        self._subscriber = hub.subscribe(name="foxglove", maxlen=QUEUE)

    # -- life ---------------------------------------------------------------------------------------------
    def start(self) -> None:
        self._subscriber.subscribe()  # every robot, every topic; the latest of each stream at once
        self._task = asyncio.get_running_loop().create_task(self._run(), name="foxglove channels")

    async def stop(self) -> None:
        self._subscriber.close()
        self._stopping = True
        if self._task is not None:
            # Python 3.11's wait_for (in the hub subscriber's wait) loses a cancellation that comes as its event
            # is set: the loop also ends by itself at the flag, within a sweep period
            self._task.cancel()
            await asyncio.wait({self._task}, timeout=2 * SWEEP_PERIOD_S)
        for stream in self.channels.values():
            stream.channel.close()
        self.channels.clear()
        for derived in self.derived:
            derived.close()

    def reset(self, shows: Callable[[HubMessage], bool]) -> None:
        """Serves other streams from now on (live robots, or a replay's): every channel closes, and the shown streams'
        channels open again with their newest message."""
        self.shows = shows
        self.newest_stamp = 0.0
        for stream in self.channels.values():
            stream.channel.close()
        self.channels.clear()
        for derived in self.derived:
            derived.close()
        self._subscriber.drain(QUEUE)  # what is queued belongs to the streams served before
        self._subscriber.subscribe()  # the newest message of each stream again

    @property
    def dropped(self) -> int:
        """Messages the hub dropped because the endpoint fell behind."""
        return self._subscriber.dropped

    async def _run(self) -> None:
        next_sweep = time.monotonic() + SWEEP_PERIOD_S
        while not self._stopping:
            await self._subscriber.wait(timeout=SWEEP_PERIOD_S)
            for msg in self._subscriber.drain(DRAIN_BATCH):
                try:
                    self.deliver(msg)
                except Exception:  # one bad message must not end the endpoint for every client
                    log.exception("foxglove: %s/%s not delivered", msg.robot, msg.topic)
            now = time.monotonic()
            if now >= next_sweep:
                next_sweep = now + SWEEP_PERIOD_S
                self.close_ended(now)
            await asyncio.sleep(0)  # a long backlog is handed over in batches, between the hub's other work

    # -- one message --------------------------------------------------------------------------------------
    def deliver(self, msg: HubMessage) -> None:
        if not self.shows(msg) or (msg.topic in self._derived_names and any(d.owns(msg) for d in self.derived)):
            return
        self.newest_stamp = max(self.newest_stamp, msg.stamp)
        key = (msg.robot, msg.topic)
        stream = self.channels.get(key)
        if stream is None or stream.typename != msg.typename:
            if stream is not None:  # the stream changed its type: a new channel with the new schema
                stream.channel.close()
                del self.channels[key]
            stream = self._open(msg)
            if stream is None:
                return
        for derived in self.derived:
            if msg.topic in derived.topics:
                try:
                    derived.offer(msg)
                except schemas.SchemaError as exc:  # CDR that does not decode: that message adds nothing
                    self.encode_errors += 1
                    log.debug("foxglove: %s/%s not decoded: %s", msg.robot, msg.topic, exc)
        if not stream.channel.has_sinks():
            return  # no client subscribed: nothing to encode or copy
        try:
            payload = msg.cdr  # the source's CDR bytes as they came; encoded here only for decoded sources
        except (schemas.SchemaError, ValueError, TypeError, AttributeError) as exc:  # counted, never fatal
            self.encode_errors += 1
            log.debug("foxglove: %s/%s not encoded: %s", msg.robot, msg.topic, exc)
            return
        stream.channel.log(payload, log_time=int(msg.stamp * 1e9))
        stream.messages += 1
        self.logged += 1

    def _open(self, msg: HubMessage) -> StreamChannel | None:
        if msg.typename in self.unschematized:
            return None
        try:
            definition = _definition(msg.typename)
        except (schemas.SchemaError, KeyError) as exc:  # a foreign type the typestore does not know
            self.unschematized.add(msg.typename)
            log.warning("foxglove: no channel for %s/%s: no definition of %s (%s)", msg.robot, msg.topic,
                        msg.typename, exc)
            return None
        schema = foxglove.Schema(name=msg.typename, encoding=SCHEMA_ENCODING, data=definition)
        channel = foxglove.Channel(channel_topic(msg.robot, msg.topic), schema=schema,
                                   message_encoding=MESSAGE_ENCODING, context=self.context,
                                   metadata={"robot": msg.robot, "source": msg.source})
        stream = self.channels[(msg.robot, msg.topic)] = StreamChannel(channel, msg.typename)
        return stream

    # -- streams that ended -------------------------------------------------------------------------------
    def close_ended(self, now: float) -> list[str]:
        """Closes the channels of streams that ended; the SDK tells every client (unadvertise)."""
        closed = []
        for key, stream in list(self.channels.items()):
            robot = self.hub.robots.get(key[0])
            stats = robot.streams.get(key[1]) if robot is not None else None
            if robot is None or stats is None or stream_ended(robot, stats, now, self.lost_after_s,
                                                              self.source_running):
                stream.channel.close()
                del self.channels[key]
                closed.append(channel_topic(*key))
        for derived in self.derived:
            for robot_id in list(derived.channels):
                if not any((robot_id, topic) in self.channels for topic in derived.topics):
                    derived.close_robot(robot_id)
        return closed


_definitions: dict[str, bytes] = {}


def _definition(typename: str) -> bytes:
    """The ros2msg text with every dependency, as MCAP recordings carry it (built once per type)."""
    text = _definitions.get(typename)
    if text is None:
        text = _definitions[typename] = schemas.msgdef(typename).encode()
    return text
