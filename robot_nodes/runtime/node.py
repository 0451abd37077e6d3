"""Node: the shape every robot node has (Zenoh session, topics by name, timers, parameters, diagnostics)."""

from __future__ import annotations

import argparse
import contextlib
import inspect
import itertools
import logging
import math
import signal
import threading
import traceback
import typing
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import zenoh

import schemas
from robot_nodes.runtime.action_server import ActionServer, ServerGoal
from robot_nodes.runtime.clock import WALL_CLOCK, Clock, RobotSimClock, sim_time_wanted
from robot_nodes.runtime.local_bus import LocalBus, RemoteInterest, freeze, thawed
from robot_nodes.runtime.loop import EventLoop, Timer, timer_period_s
from robot_nodes.runtime.parameter_server import ParameterServer
from robot_nodes.runtime.parameters import ParameterStore
from robot_nodes.runtime.rosout import RosoutHandler
from robot_nodes.runtime.service_server import ServiceServer
from schemas.codec import Message, SchemaError
from schemas.std import DiagnosticArray, DiagnosticStatus, Header, KeyValue, Time
from wire import keys
from wire.actions import ActionClient
from wire.bus import BusConfig, add_bus_arguments, bus_from_arguments, load_config_file, open_session
from wire.command_line import CommandParser
from wire.heap import freeze_startup_heap
from wire.ros2.attachment import AttachmentStamper
from wire.ros2.endpoints import declare_latched_publisher
from wire.ros2.liveliness import NodeInfo
from wire.ros2.robots import (
    next_node_id,
    node_entity,
    publisher_entity,
    robot_namespace,
    subscription_entity,
    topic_qos,
)

log = logging.getLogger(__name__)
FIRST_REPORT_AGAIN_S = 0.5  # the second report of a starting node (see spin)
MAX_PARAMETER_REQUEST = 1 << 20  # bytes of one JSON parameter request (its depth: wire.json_limits)


@dataclass
class NoParams:
    """For nodes without parameters."""


def stamp_now() -> Time:
    """A builtin_interfaces/Time of the wall clock."""
    return schemas.stamp()


def header(frame_id: str = "") -> Header:
    return schemas.header(frame_id)


def _check_handler(topic: schemas.Topic, handler: Callable[..., None], typename: str) -> None:
    """A handler whose message parameter names a message class must name the topic's: caught at setup, not in a
    match. Handlers without such an annotation (lambdas, partials) are not checked."""
    try:
        hints = typing.get_type_hints(handler)
        parameters = list(inspect.signature(handler).parameters)
    except Exception:  # annotations that do not resolve at run time, builtins: nothing to check
        return
    declared = hints.get(parameters[-1]) if parameters else None
    msgtype = getattr(declared, "__msgtype__", None)
    if isinstance(msgtype, str) and msgtype != typename:
        raise SchemaError(f"{getattr(handler, '__qualname__', handler)} takes {msgtype}, but {topic.name} carries "
                          f"{typename}")


class Publisher:
    """Publishes one topic of the table; the type comes from the table, never from the caller.

    Nodes of this process get the message object at once (the local bus); Zenoh gets its CDR only while a
    subscriber outside the process matches."""

    def __init__(self, node: Node, topic: str, robot: str) -> None:
        self.topic = schemas.topic(topic)
        self.robot = robot
        self.key = keys.topic_key(robot, topic)
        # the rmw_zenoh entity this publisher is: every sample carries its attachment (ROS 2 drops those without)
        self.entity = publisher_entity(node.zid, robot, node.name, topic, node.ros2_node_id,
                                       node.next_entity_id(), keys.domain_id())
        self._stamp = AttachmentStamper(self.entity.gid)
        self._token = node.session.liveliness().declare_token(self.entity.token)  # ros2 topic list/info see it
        encoding = zenoh.Encoding("application/cdr").with_schema(self.topic.type)
        self._pub: Any
        self._remote: RemoteInterest | AlwaysPut
        if self.topic.latched:
            # kept for subscribers that join later (ROS 2's transient local), so put whether or not one listens now
            self._pub = declare_latched_publisher(node.session, self.key, topic_qos(topic), encoding,
                                                  zenoh.Locality.REMOTE)
            self._remote = AlwaysPut()
        else:
            self._pub = node.session.declare_publisher(self.key, encoding=encoding,
                                                       allowed_destination=zenoh.Locality.REMOTE)
            self._remote = RemoteInterest(self._pub)
        self._local = node.local_bus
        self._typename = schemas.codec.full_name(self.topic.type)
        self.count = 0
        self.encoded = 0  # messages encoded for subscribers outside the process

    def publish(self, msg: Message) -> None:
        if msg.__msgtype__ != self._typename:
            raise SchemaError(f"{self.topic.name} carries {self._typename}, not {msg.__msgtype__}")
        cdr = None
        local = self._local.local_subscribers(self.robot, self.topic.name)
        if local:
            freeze(msg)  # shared with the nodes of this process from now on
            cdr = schemas.encode(msg) if self._local.check_frozen else None
            for subscription in local:
                subscription.hand_over_local(self.robot, msg, cdr)
        elif self._local.check_frozen:
            freeze(msg)  # the tests: a node that changes what it published fails alone as it would composed
        if self._remote.matching:
            payload = cdr if cdr is not None else schemas.encode(msg)
            self.encoded += 1  # before the put: a subscriber may have it before this thread runs again
            self._pub.put(payload, attachment=self._stamp.next())
        self.count += 1

    def publish_bytes(self, payload: bytes) -> None:
        """Already-encoded CDR (relays, replay): decoded only for subscribers in this process."""
        local = self._local.local_subscribers(self.robot, self.topic.name)
        if local:
            msg = schemas.decode(payload, self.topic.type)
            freeze(msg)
            for subscription in local:
                subscription.hand_over_local(self.robot, msg, payload if self._local.check_frozen else None)
        if self._remote.matching:
            self._pub.put(payload, attachment=self._stamp.next())
        self.count += 1

    @property
    def has_subscribers(self) -> bool:
        """Someone listens: a node of this process or a subscriber elsewhere."""
        return self._remote.matching or bool(self._local.local_subscribers(self.robot, self.topic.name))

    def close(self) -> None:
        self._token.undeclare()
        self._remote.close()
        self._pub.undeclare()


class AlwaysPut:
    """The remote interest of a latched publisher: its cache is for subscribers that are not there yet, so every
    message goes out (zenoh-ext's advanced publisher has no matching status to ask)."""

    matching = True

    def close(self) -> None:
        """Nothing to undeclare."""


QUEUE_DEPTH = 1000  # messages of one subscription waiting for the node's loop: 10 s of a 100 Hz topic


class Subscription:
    """One topic of the table into a node's loop: from nodes of this process as objects, from elsewhere decoded
    once per process (robot_nodes/runtime/local_bus.py)."""

    def __init__(self, node: Node, topic: str, handler: Callable[..., None], robot: str,
                 max_hz: float | None = None) -> None:
        self.topic = schemas.topic(topic)
        _check_handler(self.topic, handler, schemas.codec.full_name(self.topic.type))
        self.handler = handler
        self.robot = robot
        self.any_robot = robot == keys.ANY_ROBOT
        self.count = 0
        self.decode_errors = 0
        self.skipped = 0  # messages dropped by max_hz before they woke the node
        self.queued = 0  # handed to the node's loop, not yet delivered
        self.overflowed = 0  # messages dropped because QUEUE_DEPTH were already waiting (the node fell behind)
        self.max_hz = max_hz
        self._last_taken = -math.inf
        self._node = node
        self._clock = node.clock
        self._call_soon = node.loop.call_soon
        self._check_frozen = node.local_bus.check_frozen
        # its tokens on the ROS 2 graph (ros2 topic info -v): one for its robot's topic; a subscription to every
        # robot's topic has no single ROS 2 name, so it declares one per robot it hears from (as if it had
        # subscribed to each robot's topic by name), when the first message of that robot arrives
        self._tokens: dict[str, Any] = {}
        if not self.any_robot:
            self._declare_token(robot)
        node.local_bus.add(self)

    def _declare_token(self, robot: str) -> None:
        node = self._node
        try:
            self._tokens[robot] = node.session.liveliness().declare_token(subscription_entity(
                node.zid, node.robot_id, node.name, self.topic.name, node.ros2_node_id, node.next_entity_id(),
                keys.domain_id(), topic_robot=robot).token)
        except Exception as exc:  # a robot id ROS 2 cannot name, a closed session: the data still flows
            self._tokens[robot] = None
            node.log.debug("%s of %s not on the ROS 2 graph: %s", self.topic.name, robot, exc)

    @property
    def max_hz(self) -> float | None:
        """At most this many messages a second reach the handler (10 % slack for a publisher's jitter); the others
        are dropped on the delivering thread, so they never wake the node."""
        return 0.9 / self._min_interval if self._min_interval else None

    @max_hz.setter
    def max_hz(self, hz: float | None) -> None:
        self._min_interval = 0.9 / hz if hz else 0.0

    def _taken(self) -> bool:
        """max_hz: whether this message is handed on (the caller asks only when a rate is set)."""
        now = self._clock.now()
        if now - self._last_taken < self._min_interval:
            self.skipped += 1
            return False
        self._last_taken = now
        return True

    def _room(self) -> bool:
        """Whether one more message may wait for the node's loop: at most QUEUE_DEPTH per subscription, as a ROS 2
        subscription's history depth, so a node that falls behind drops (and counts) instead of growing."""
        if self.queued >= QUEUE_DEPTH:
            self.overflowed += 1
            return False
        self.queued += 1
        return True

    def hand_over(self, key: str, msg: Message | SchemaError) -> None:
        """A sample from outside the process (any thread)."""
        if (isinstance(msg, SchemaError) or not self._min_interval or self._taken()) and self._room():
            self._call_soon(self._queued_remote, key, msg)

    def hand_over_cdr(self, key: str, cdr: bytes) -> None:
        """A sample from outside the process for this subscription alone (a Zenoh thread): decoded on the loop."""
        if (not self._min_interval or self._taken()) and self._room():
            self._call_soon(self._deliver_cdr, key, cdr)

    def hand_over_local(self, robot: str, msg: Message, cdr: bytes | None) -> None:
        """A message a node of this process published (its thread); cdr: its encoding, to check it stays frozen."""
        if (not self._min_interval or self._taken()) and self._room():
            self._call_soon(self._queued_local, robot, msg, cdr)

    def _queued_remote(self, key: str, msg: Message | SchemaError) -> None:
        self.queued -= 1
        self._deliver_remote(key, msg)

    def _queued_local(self, robot: str, msg: Message, cdr: bytes | None) -> None:
        self.queued -= 1
        self._deliver(robot, msg, cdr)

    def _deliver_cdr(self, key: str, cdr: bytes) -> None:
        """The lone subscriber's path: decoded here, given to the handler; not shared, so not frozen (but in the
        tests, where a node that changes a received message fails alone as it would composed)."""
        self.queued -= 1
        try:
            msg = schemas.decode(cdr, self.topic.type)
        except SchemaError as exc:
            self._deliver_remote(key, exc)
            return
        if self.any_robot or self._check_frozen or self.topic.root:
            if self._check_frozen:
                freeze(msg)
            self._deliver_remote(key, msg)
            return
        self.count += 1
        self.handler(msg)

    def _deliver_remote(self, key: str, msg: Message | SchemaError) -> None:
        if isinstance(msg, SchemaError):
            self.decode_errors += 1
            self._node.record_error(f"{self.topic.name}: {msg}")
            return
        robot = self.robot
        if self.topic.root:
            # /rosout is every robot's: the message says whose, and a subscription to one robot's takes its own
            try:
                robot = keys.robot_of_message(self.topic.name, msg)
            except ValueError:  # a ROS 2 node of the root namespace (no robot's), or a name that breaks the rules
                return
            if not self.any_robot and robot != self.robot:
                return
        elif self.any_robot:
            try:
                robot = keys.split_topic_key(key)[0]
            except ValueError as exc:  # a robot id that breaks the rules: someone else's process on the bus
                self.decode_errors += 1
                self._node.record_error(str(exc))
                return
        self._deliver(robot, msg, None)

    def _deliver(self, robot: str, msg: Message, cdr: bytes | None) -> None:
        self.count += 1
        if self.any_robot and robot not in self._tokens:
            self._declare_token(robot)
        # the frozen check (tests): blame this handler only if the message was intact when it got it
        intact = cdr is not None and schemas.encode(msg) == cdr
        if self.any_robot:
            self.handler(robot, msg)
        else:
            self.handler(msg)
        if intact and schemas.encode(msg) != cdr:
            raise thawed(f"{self.topic.name}: a {msg.__msgtype__} changed after it was published (found after "
                         f"{getattr(self.handler, '__qualname__', self.handler)} of {self._node.name})")

    def close(self) -> None:
        for token in self._tokens.values():
            if token is not None:
                with contextlib.suppress(Exception):  # gone with the session already
                    token.undeclare()
        self._tokens.clear()
        self._node.local_bus.remove(self)


class LatestMessage(Subscription):
    """The newest message of one of this robot's topics, kept without waking the node: for a node that reads a
    topic when it ticks (walking reads the IMU each cycle) rather than acting on every message.

    ``message`` is None until the first arrives; ``received_at`` is when it arrived (``Node.now()``)."""

    def __init__(self, node: Node, topic: str, robot: str) -> None:
        super().__init__(node, topic, _kept, robot)
        self.message: Any = None  # the topic's class
        self.received_at = -math.inf

    def hand_over(self, key: str, msg: Message | SchemaError) -> None:
        if isinstance(msg, SchemaError):
            super().hand_over(key, msg)  # counted and reported on the node's loop, as for a handler
        else:
            self._keep(msg)

    def hand_over_cdr(self, key: str, cdr: bytes) -> None:
        try:
            msg = schemas.decode(cdr, self.topic.type)
        except SchemaError as exc:
            super().hand_over(key, exc)
        else:
            if self._check_frozen:
                freeze(msg)
            self._keep(msg)

    def hand_over_local(self, robot: str, msg: Message, cdr: bytes | None) -> None:
        self._keep(msg)

    def _keep(self, msg: Message) -> None:
        self.message, self.received_at = msg, self._clock.now()  # one reference: atomic for the reading loop
        self.count += 1


def _kept(msg: Message) -> None:
    """A LatestMessage has no handler: the node reads ``message``."""


class Node:
    """Base of every robot node.

    Subclasses set ``name`` and ``Params`` (a dataclass of ``param`` fields), and build their
    publishers, subscriptions and timers in ``setup``. All callbacks run on the node's one loop
    thread, so node code needs no locks. Its timers and ``now()`` follow its clock: the wall clock, or its robot's
    simulated clock when the process simulates (robot_nodes/runtime/clock.py).
    """

    name: ClassVar[str] = "node"
    Params: ClassVar[type] = NoParams
    diagnostics_period: ClassVar[float] = 1.0

    def __init__(
        self,
        robot_id: str = "robot1",
        bus: BusConfig | zenoh.Session | None = None,
        params_file: Path | None = None,
        overrides: dict[str, Any] | None = None,
        clock: Clock | None = None,
        loop: EventLoop | None = None,
    ) -> None:
        self.robot_id = robot_id
        self.ros2_node_id = next_node_id()  # the node's id among the ROS 2 nodes of this process (rmw_zenoh's)
        self._entity_ids = itertools.count(self.ros2_node_id + 1)
        # one logger per node instance (two robots' HCMs in one process log apart); its records also go on rosout
        self.log = logging.getLogger(f"pitchside.{robot_id}.{self.name}")
        self._own_session = not isinstance(bus, zenoh.Session)
        self.session: zenoh.Session = bus if isinstance(bus, zenoh.Session) else open_session(bus)
        self.local_bus = LocalBus.join(self.session)  # nodes of this process hand messages over as objects
        self.zid = str(self.session.zid())
        # the node on the ROS 2 graph (ros2 node list: /<robot>/<name>), gone with the node or its session
        ros2_node = node_entity(self.zid, robot_id, self.name, self.ros2_node_id, keys.domain_id())
        self._ros2_token = self.session.liveliness().declare_token(ros2_node.token)
        self._robot_clock: RobotSimClock | None = None
        if clock is None and sim_time_wanted():
            clock = self._robot_clock = RobotSimClock.join(self.local_bus, robot_id)
        self.clock: Clock = clock or WALL_CLOCK
        # a loop of its own, or one it shares with other nodes of the process (NodesOnOneLoop, one_loop.py)
        self._loop_shared = loop is not None
        if loop is not None and loop.clock is not self.clock:
            raise ValueError(f"{self.name}: a shared loop runs on its own clock; give the node that clock")
        self.loop = loop if loop is not None else EventLoop(self._on_callback_error, self.clock)
        self.parameters = ParameterStore(self.name, self.Params, params_file, overrides)
        self.params = self.parameters.values
        self.parameters.on_change(lambda changed: self.loop.call_soon(self.on_parameters_changed, changed))
        self._publishers: list[Publisher] = []
        self._subscriptions: list[Subscription] = []
        self._timers: list[Timer] = []
        self._declared: list[Any] = []  # queryables, servers and clients to close with the node
        self._services: list[ServiceServer] = []
        self.errors = 0
        self.last_error = ""
        self._diag_values: dict[str, str] = {}
        self._thread: threading.Thread | None = None
        self._started = self.clock.now()
        self._closed = False
        self._closed_done = threading.Event()
        self._diag_pub = self.publisher("diagnostics")
        self._rosout_publisher = self.publisher("rosout")  # ROS 2's /rosout, every robot's (its logger name says whose)
        self._rosout = RosoutHandler(self._rosout_publisher.publish, keys.logger_name(robot_id, self.name))
        self.log.addHandler(self._rosout)
        # ros2 param list/get/set /<robot>/<node>, the dashboard's parameter panel, /parameter_events
        self._parameter_server = ParameterServer(self.session, self.ros2_node_info, self.zid, self.ros2_node_id,
                                                 self.next_entity_id, self.parameters)
        self._declared.append(self._parameter_server)
        self.timer(self._publish_diagnostics, period_s=self.diagnostics_period)
        try:
            self.setup()
        except BaseException:  # a node that cannot start leaves no session behind (it would hold the process)
            self.loop.stop()
            self._close()
            raise

    # -- for subclasses -------------------------------------------------------------------------------
    def now(self) -> float:
        """Seconds of the node's clock (monotonic; simulated time in a simulation): for ages and durations."""
        return self.clock.now()

    def setup(self) -> None:
        """Declare publishers, subscriptions and timers here."""

    def on_parameters_changed(self, changed: dict[str, Any]) -> None:
        """Called on the loop thread after parameters changed live."""

    def on_shutdown(self) -> None:
        """Last words before the session closes (e.g. switch motors off)."""

    def next_entity_id(self) -> int:
        """An id for one of the node's publishers, subscriptions, services or clients (rmw_zenoh's entity id)."""
        return next(self._entity_ids)

    def publisher(self, topic: str) -> Publisher:
        pub = Publisher(self, topic, self.robot_id)
        self._publishers.append(pub)
        return pub

    def subscribe(self, topic: str, handler: Callable[..., None], robot: str | None = None,
                  max_hz: float | None = None) -> Subscription:
        """handler(msg) for this robot's topic; with robot="*", handler(robot_id, msg) for every robot. max_hz: at
        most this many messages a second, the others dropped before they wake the node."""
        sub = Subscription(self, topic, handler, robot or self.robot_id, max_hz)
        self._subscriptions.append(sub)
        return sub

    def keep_latest(self, topic: str) -> LatestMessage:
        """The newest message of this robot's topic, kept without waking the node (read it when you tick)."""
        sub = LatestMessage(self, topic, self.robot_id)
        self._subscriptions.append(sub)
        return sub

    def timer(self, callback: Callable[[], None], *, rate_hz: float | None = None, period_s: float | None = None,
              name: str | None = None) -> Timer:
        """``callback`` on the node's loop ``rate_hz`` times a second or every ``period_s`` seconds of the node's
        clock: exactly one of the two, named, so a rate is never read as a period (rclpy's ``create_timer`` takes
        the period: a ``timer(0.01, ...)`` there is 100 Hz)."""
        t = Timer(self.loop, timer_period_s(rate_hz, period_s), callback,
                  name or str(getattr(callback, "__name__", "timer")))
        self._timers.append(t)
        self.loop.add_timer(t) if self.loop.thread is None else self.loop.call_soon(self.loop.add_timer, t)
        return t

    def action_server(self, action: str, on_goal: Callable[[ServerGoal], str | None],
                      on_cancel: Callable[[ServerGoal], None] | None = None,
                      on_preempt: Callable[[ServerGoal], None] | None = None) -> ActionServer:
        server = ActionServer(self.session, self.loop, self.robot_id, action, on_goal, on_cancel, on_preempt,
                              node=self.ros2_node_info, node_id=self.ros2_node_id, entity_ids=self.next_entity_id,
                              log=self.log.info, diagnostic=self.set_diagnostic)
        self._declared.append(server)
        return server

    def action_client(self, action: str, robot: str | None = None) -> ActionClient:
        """Its callbacks run on this node's loop."""
        client = ActionClient(self.session, robot or self.robot_id, action, self.loop, node=self.ros2_node_info,
                              node_id=self.ros2_node_id, entity_ids=self.next_entity_id)
        self._declared.append(client)
        return client

    @property
    def ros2_node_info(self) -> NodeInfo:
        """The node as ROS 2 names it: /<robot>/<name> in the domain."""
        return NodeInfo(keys.domain_id(), robot_namespace(self.robot_id), self.name)

    def service(self, name: str, handler: Callable[[Any], Message]) -> ServiceServer:
        """A service of the table as the ROS 2 service /<robot>/<name>; handler(request) runs on the loop."""
        server = ServiceServer(self.session, self.loop, self.ros2_node_info, self.ros2_node_id, self.next_entity_id(),
                               self.robot_id, name, handler)
        self._services.append(server)
        self._declared.append(server)
        return server

    def set_diagnostic(self, key: str, value: Any) -> None:
        self._diag_values[key] = str(value)

    def publish_diagnostics(self) -> None:
        """Send diagnostics now (they also go out every diagnostics_period)."""
        self._publish_diagnostics()

    def record_error(self, message: str) -> None:
        """Counted and shown in diagnostics; the node goes on."""
        self.errors += 1
        self.last_error = message
        self.log.warning(message)

    # -- running --------------------------------------------------------------------------------------
    def spin(self) -> None:
        """Runs the loop on this thread until shutdown()."""
        if self._loop_shared:
            raise RuntimeError(f"{self.name} shares a loop: its NodesOnOneLoop runs it")
        self.schedule_first_reports()
        try:
            self.loop.run()
        finally:
            self._close()

    def schedule_first_reports(self) -> None:
        """The first report goes out as soon as the node runs, not a period later: a restarted node that only
        reports (speaker, an idle animation player) shows it is back at once. A second follows shortly: a new
        session's first puts can leave before its routes to the subscribers are known, and are then lost."""
        self.loop.call_soon(self._publish_diagnostics)

        def report_again() -> None:
            again.cancel()
            self._publish_diagnostics()

        again = Timer(self.loop, FIRST_REPORT_AGAIN_S, report_again, "first_diagnostics")
        self.loop.add_timer(again) if self.loop.thread is None else self.loop.call_soon(self.loop.add_timer, again)

    def start(self) -> Node:
        """Runs the loop on a background thread (tests, several nodes in one process)."""
        if self._loop_shared:
            raise RuntimeError(f"{self.name} shares a loop: its NodesOnOneLoop starts it")
        self._thread = threading.Thread(target=self.spin, name=f"node-{self.name}", daemon=True)
        self._thread.start()
        return self

    @property
    def closed(self) -> bool:
        """Shut down or shutting down (a node alone: its loop ended; on a shared loop: it left it)."""
        return self._closed

    def wait_closed(self, timeout: float) -> bool:
        """Until the node has shut down (its entities closed), at most ``timeout`` seconds."""
        return self._closed_done.wait(timeout)

    def request_shutdown(self) -> None:
        """What SIGINT/SIGTERM call: a node with last duties (e.g. the HCM sitting down) overrides it."""
        self.shutdown()

    def shutdown(self) -> None:
        """on_shutdown on the node's loop, then the loop stops; a node on a shared loop leaves it instead (its
        timers off, its entities closed) and the loop runs on for the other nodes (one_loop.py)."""
        shared = self._loop_shared
        if self._closed or (self.loop.stopped and not shared):
            return
        done = threading.Event()

        def leave() -> None:
            if shared:
                for timer in self._timers:
                    timer.cancel()
                self._close()
            else:
                self.loop.stop()

        def last_words() -> None:
            try:
                self.on_shutdown()
            finally:
                leave()
                done.set()

        if self.loop.thread is None or self.loop.stopped:
            leave()
            self._close()
            return
        if threading.current_thread() is self.loop.thread:
            last_words() if shared else self.loop.call_soon(last_words)
            return
        self.loop.call_soon(last_words)
        done.wait(5.0)
        if self._thread is not None:
            self._thread.join(5.0)

    def _close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            self.log.removeHandler(self._rosout)
            entities: list[Publisher | Subscription] = [*self._subscriptions, *self._publishers]
            for entity in entities:
                with contextlib.suppress(Exception):  # already gone with the session
                    entity.close()
            for declared in self._declared:
                with contextlib.suppress(Exception):
                    declared.close() if hasattr(declared, "close") else declared.undeclare()
            with contextlib.suppress(Exception):
                self._ros2_token.undeclare()
            if self._robot_clock is not None:
                self._robot_clock.leave()
            self.local_bus.leave()
            if self._own_session:
                self.session.close()
        finally:
            self._closed_done.set()

    # -- internals ------------------------------------------------------------------------------------
    def _on_callback_error(self, callback: Callable[..., Any], exc: BaseException) -> None:
        where = getattr(callback, "__qualname__", repr(callback))
        self.record_error(f"{where}: {type(exc).__name__}: {exc}")
        self.log.debug("".join(traceback.format_exception(exc)))

    def _publish_diagnostics(self) -> None:
        uptime = self.clock.now() - self._started
        values = {
            "uptime_s": f"{uptime:.1f}",
            "errors": str(self.errors),
            "last_error": self.last_error,
            "decode_errors": str(sum(s.decode_errors for s in self._subscriptions)),
            "queue_overflows": str(sum(s.overflowed for s in self._subscriptions)),
            "rosout_dropped": str(self._rosout.dropped),
            # requests without an attachment, that did not decode, or that a handler failed on
            "bad_service_requests": str(self._parameter_server.bad_requests
                                        + sum(s.bad_requests for s in self._services)),
        }
        for t in self._timers:
            if t.callback != self._publish_diagnostics:
                values[f"rate_hz/{t.name}"] = f"{t.ticks / max(uptime, 1e-3):.1f}"
        values.update(self._diag_values)
        level = 1 if self.last_error else 0
        status = schemas.make(
            DiagnosticStatus,
            level=level,
            name=f"{self.robot_id}/{self.name}",
            message=self.last_error or "OK",
            hardware_id=self.robot_id,
            values=[schemas.make(KeyValue, key=k, value=v) for k, v in values.items()],
        )
        self._diag_pub.publish(schemas.make(DiagnosticArray, header=header(), status=[status]))


def node_arguments(description: str) -> argparse.ArgumentParser:
    parser = CommandParser(description=description)
    parser.add_argument("--robot-id", default="robot1", help="robot id in the Zenoh keys (default robot1)")
    add_bus_arguments(parser)
    parser.add_argument("--params", type=Path, default=None, help="params.yaml of the robot")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="override a parameter (YAML value syntax)")
    parser.add_argument("--log-level", default="INFO")
    return parser


def parse_overrides(items: list[str]) -> dict[str, Any]:
    import yaml

    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep:
            raise SystemExit(f"--set expects NAME=VALUE, got {item!r}")
        out[name.strip()] = yaml.safe_load(value)
    return out


def run(node_cls: type[Node], argv: list[str] | None = None, **kwargs: Any) -> None:
    """Process entry point of a node: parse arguments, spin, stop cleanly on SIGINT/SIGTERM."""
    args = node_arguments(node_cls.__doc__ or node_cls.name).parse_args(argv)
    logging.basicConfig(level=args.log_level, format=f"%(asctime)s %(levelname)s [{node_cls.name}] %(message)s")
    bus = bus_from_arguments(args)
    if args.zenoh_config:
        try:
            load_config_file(args.zenoh_config)  # a wrong path is said once, not retried as a missing router
        except ValueError as exc:
            raise SystemExit(f"{node_cls.name}: {exc}") from None
    stop_requested: list[int] = []
    holder: list[Node] = []

    def stop(signum: int, _frame: Any) -> None:
        stop_requested.append(signum)
        if holder:
            holder[0].log.info("stopping on %s", signal.Signals(signum).name)
            holder[0].loop.call_soon(holder[0].request_shutdown)

    # handlers first: a signal that comes while the node is still starting must stop it cleanly too
    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)
    node = node_cls(robot_id=args.robot_id, bus=bus, params_file=args.params,
                    overrides=parse_overrides(args.set), **kwargs)
    holder.append(node)
    if stop_requested:
        node.shutdown()
        return
    node.log.info("%s up for robot %s", node_cls.name, args.robot_id)
    freeze_startup_heap()
    node.spin()
