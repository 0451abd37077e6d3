"""A ROS 2 node on rmw_zenoh's wire: its liveliness tokens, publishers that attach what rmw_zenoh checks, and
subscriptions that take samples only with a valid attachment (as rmw_zenoh drops them without).

Payloads are CDR with the 4-byte encapsulation header (schemas.codec.encode); these classes move bytes and leave
decoding to the caller, so a type pitchside has no class for still passes through.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Any

import zenoh
import zenoh.ext

from wire.ros2.attachment import Attachment, decode_attachment
from wire.ros2.errors import Ros2WireError
from wire.ros2.keys import TopicKey
from wire.ros2.liveliness import Entity, EntityKind, NodeInfo
from wire.ros2.qos import Durability, QoS, Reliability

log = logging.getLogger(__name__)
# rmw_zenoh's SAMPLE_MISS_DETECTION_HEARTBEAT_PERIOD (500 ms): how often a reliable latched publisher says how far it is
HEARTBEAT_PERIOD_S = 0.5

SampleCallback = Callable[[bytes, Attachment], None]
# a service's work: CDR request and its attachment in, CDR response out
ServiceHandler = Callable[[bytes, Attachment], bytes]


class Ros2ServiceError(Exception):
    """A service call that got no reply, or an error reply, in time."""


class Ros2ServiceUnanswered(Ros2ServiceError):
    """No server answered in time (none there yet, or gone): a caller may try again."""


ZENOH_TIMEOUT = "Timeout"  # the error reply Zenoh itself gives a query that no queryable answered in time


class Ros2Node:
    """A node's NN token and the ids of its entities (the node id is its first entity id, as in rmw_zenoh)."""

    def __init__(self, session: zenoh.Session, info: NodeInfo, node_id: int = 0) -> None:
        self.session = session
        self.info = info
        self.node_id = node_id
        self.zid = str(session.zid())
        self._next_id = node_id + 1
        self._lock = threading.Lock()
        self.entity = Entity(self.zid, node_id, node_id, EntityKind.NODE, info)
        self._token = session.liveliness().declare_token(self.entity.token)

    def _entity(self, kind: EntityKind, topic: TopicKey, qos: QoS) -> Entity:
        with self._lock:
            entity_id, self._next_id = self._next_id, self._next_id + 1
        return Entity(self.zid, self.node_id, entity_id, kind, self.info, topic, qos)

    def create_publisher(self, name: str, ros_type: str, type_hash: str, qos: QoS | None = None) -> Ros2Publisher:
        topic = TopicKey(self.info.domain_id, name, ros_type, type_hash)
        return Ros2Publisher(self.session, self._entity(EntityKind.PUBLISHER, topic, qos or QoS(depth=10)))

    def create_subscription(self, name: str, ros_type: str, type_hash: str, callback: SampleCallback,
                            qos: QoS | None = None) -> Ros2Subscription:
        topic = TopicKey(self.info.domain_id, name, ros_type, type_hash)
        return Ros2Subscription(self.session, self._entity(EntityKind.SUBSCRIPTION, topic, qos or QoS(depth=10)),
                                callback)

    def create_service(self, name: str, srv_type: str, type_hash: str, handler: ServiceHandler) -> Ros2Service:
        topic = TopicKey(self.info.domain_id, name, srv_type, type_hash)
        return Ros2Service(self.session, self._entity(EntityKind.SERVICE, topic, QoS(depth=10)), handler)

    def create_client(self, name: str, srv_type: str, type_hash: str) -> Ros2Client:
        topic = TopicKey(self.info.domain_id, name, srv_type, type_hash)
        return Ros2Client(self.session, self._entity(EntityKind.CLIENT, topic, QoS(depth=10)))

    def close(self) -> None:
        self._token.undeclare()


def declare_latched_publisher(session: zenoh.Session, keyexpr: str, qos: QoS,
                              encoding: zenoh.Encoding | None = None,
                              allowed_destination: zenoh.Locality | None = None) -> Any:
    """A transient local (latched) publisher as rmw_zenoh declares one: a zenoh-ext advanced publisher that keeps
    its last ``qos.depth`` samples for late subscribers, detectable through liveliness, with sporadic heartbeats
    when reliable (so a subscriber notices a sample it missed)."""
    reliable = qos.reliability is not Reliability.BEST_EFFORT
    heartbeat = zenoh.ext.MissDetectionConfig(heartbeat=None, sporadic_heartbeat=HEARTBEAT_PERIOD_S)
    return zenoh.ext.declare_advanced_publisher(
        session, keyexpr, encoding=encoding,
        reliability=zenoh.Reliability.RELIABLE if reliable else zenoh.Reliability.BEST_EFFORT,
        congestion_control=zenoh.CongestionControl.DROP, allowed_destination=allowed_destination,
        cache=zenoh.ext.CacheConfig(max_samples=qos.depth), publisher_detection=True,
        sample_miss_detection=heartbeat if reliable else None)


class Ros2Publisher:
    """Puts CDR bytes on the topic's key with the attachment (sequence number from 1, time, GID). A transient local
    (latched) publisher keeps its last ``depth`` samples for late subscribers, as rmw_zenoh's does: a zenoh-ext
    advanced publisher with a cache, detectable through liveliness, with sporadic heartbeats when reliable."""

    def __init__(self, session: zenoh.Session, entity: Entity) -> None:
        assert entity.topic is not None and entity.qos is not None
        self.entity = entity
        self.gid = entity.gid
        self._sequence_number = 0
        self._lock = threading.Lock()
        reliable = entity.qos.reliability is not Reliability.BEST_EFFORT
        reliability = zenoh.Reliability.RELIABLE if reliable else zenoh.Reliability.BEST_EFFORT
        self._publisher: Any
        if entity.qos.durability is Durability.TRANSIENT_LOCAL:
            self._publisher = declare_latched_publisher(session, entity.topic.keyexpr, entity.qos)
        else:
            self._publisher = session.declare_publisher(
                entity.topic.keyexpr, reliability=reliability, congestion_control=zenoh.CongestionControl.DROP)
        self._token = session.liveliness().declare_token(entity.token)

    def publish(self, payload: bytes) -> Attachment:
        with self._lock:
            self._sequence_number += 1
            attachment = Attachment(self._sequence_number, time.time_ns(), self.gid)
        self._publisher.put(payload, attachment=attachment.encode())
        return attachment

    def close(self) -> None:
        self._token.undeclare()
        self._publisher.undeclare()


class Ros2Subscription:
    """Hands each sample with a valid attachment to the callback; the others are counted (the first logged). A
    transient local subscription also asks latched publishers for what they kept (late joiners included), as
    rmw_zenoh's advanced subscriber does."""

    def __init__(self, session: zenoh.Session, entity: Entity, callback: SampleCallback) -> None:
        assert entity.topic is not None
        self.entity = entity
        self.dropped = 0
        self._callback = callback
        self._subscriber: Any
        qos = entity.qos or QoS()
        if qos.durability is Durability.TRANSIENT_LOCAL:
            self._subscriber = zenoh.ext.declare_advanced_subscriber(
                session, entity.topic.keyexpr, self._on_sample, subscriber_detection=True,
                history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=qos.depth),
                recovery=zenoh.ext.RecoveryConfig(periodic_queries=None, heartbeat=True)
                if qos.reliability is not Reliability.BEST_EFFORT else None)
        else:
            self._subscriber = session.declare_subscriber(entity.topic.keyexpr, self._on_sample)
        self._token = session.liveliness().declare_token(entity.token)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        try:
            if sample.attachment is None:
                raise Ros2WireError("sample without an attachment")
            attachment = decode_attachment(sample.attachment.to_bytes())
        except Ros2WireError as exc:
            self.dropped += 1
            if self.dropped == 1:
                log.warning("dropping samples on %s that rmw_zenoh would drop too (further ones only counted): %s",
                            sample.key_expr, exc)
            return
        self._callback(sample.payload.to_bytes(), attachment)

    def close(self) -> None:
        self._token.undeclare()
        self._subscriber.undeclare()


class Ros2Service:
    """A service server as rmw_zenoh's: a complete queryable on the service's key; a request without a valid
    attachment is dropped (counted), a reply carries the request's sequence number and client GID."""

    def __init__(self, session: zenoh.Session, entity: Entity, handler: ServiceHandler,
                 dispatch: Callable[[Callable[[], None]], None] | None = None) -> None:
        """``dispatch``: where the handler runs (e.g. a node's loop); None: on the Zenoh thread of the request."""
        assert entity.topic is not None
        self.entity = entity
        self.dropped = 0
        self.failed = 0  # requests the handler raised on: answered with an error reply
        self._handler = handler
        self._dispatch = dispatch
        self._queryable: Any = session.declare_queryable(entity.topic.keyexpr, self._on_query, complete=True)
        self._token = session.liveliness().declare_token(entity.token)

    def _on_query(self, query: zenoh.Query) -> None:
        assert self.entity.topic is not None
        try:
            if query.attachment is None:
                raise Ros2WireError("request without an attachment")
            request = decode_attachment(query.attachment.to_bytes())
        except Ros2WireError as exc:
            self.dropped += 1
            if self.dropped == 1:
                log.warning("dropping requests on %s that rmw_zenoh would drop too (further ones only counted): %s",
                            self.entity.topic.name, exc)
            return
        payload = query.payload.to_bytes() if query.payload is not None else b""
        if self._dispatch is None:
            self._answer(query, payload, request)
        else:
            self._dispatch(lambda: self._answer(query, payload, request))

    def _answer(self, query: zenoh.Query, payload: bytes, request: Attachment) -> None:
        assert self.entity.topic is not None
        try:
            try:
                response = self._handler(payload, request)
            except Exception as exc:  # a bad request or a bug in the handler: the caller hears why, the server stays
                self.failed += 1
                log.warning("service %s failed on a request: %s", self.entity.topic.name, exc)
                query.reply_err(f"{self.entity.topic.name}: {exc}")
                return
            reply = Attachment(request.sequence_number, time.time_ns(), request.gid)
            query.reply(self.entity.topic.keyexpr, response, attachment=reply.encode())
        finally:  # the query is finished now, not when Python collects it (an exception's traceback holds it)
            query.drop()

    def close(self) -> None:
        self._token.undeclare()
        self._queryable.undeclare()


class Ros2Client:
    """A service client as rmw_zenoh's: a get to every complete queryable, with the attachment."""

    def __init__(self, session: zenoh.Session, entity: Entity) -> None:
        assert entity.topic is not None
        self.entity = entity
        self.gid = entity.gid
        self._session = session
        self._sequence_number = 0
        self._lock = threading.Lock()
        self._token = session.liveliness().declare_token(entity.token)

    def call(self, request: bytes, timeout_s: float = 5.0) -> tuple[bytes, Attachment]:
        """The CDR response and its attachment; Ros2ServiceError if no server answers in time or it fails."""
        assert self.entity.topic is not None
        with self._lock:
            self._sequence_number += 1
            sent = Attachment(self._sequence_number, time.time_ns(), self.gid)
        replies = self._session.get(self.entity.topic.keyexpr, target=zenoh.QueryTarget.ALL_COMPLETE,
                                    payload=request, attachment=sent.encode(), timeout=timeout_s)
        for reply in replies:
            if reply.ok is None:
                why = reply.err.payload.to_string() if reply.err is not None else "an empty reply"
                if why == ZENOH_TIMEOUT:
                    break
                raise Ros2ServiceError(f"{self.entity.topic.name}: {why}")
            sample = reply.ok
            if sample.attachment is None:
                raise Ros2ServiceError(f"{self.entity.topic.name}: a reply without an attachment")
            attachment = decode_attachment(sample.attachment.to_bytes())
            if attachment.sequence_number != sent.sequence_number or attachment.gid != self.gid:
                raise Ros2ServiceError(f"{self.entity.topic.name}: a reply to request {attachment.sequence_number},"
                                       f" not to {sent.sequence_number}")
            return sample.payload.to_bytes(), attachment
        raise Ros2ServiceUnanswered(f"{self.entity.topic.name}: no server answered within {timeout_s} s")

    def close(self) -> None:
        self._token.undeclare()
