"""In-process delivery between the nodes of one process: what ROS 2 calls intra-process communication.

Nodes that share a process share its Zenoh session and the session's LocalBus. A message one of them publishes is
handed to the other nodes' loops as the same object, in publish order, without CDR and without Zenoh; it is
encoded for Zenoh only while a subscriber outside the process matches (the publisher's destination is "remote",
so Zenoh's matching status counts only those). A sample from outside the process is decoded once: on the loop of
its only subscriber in the process (as a node alone does), or on the Zenoh thread for several, which then share
the object.

The rule that makes one object safe for many subscribers: **a published message is frozen**. Neither its
publisher nor any subscriber changes it afterwards; a node that wants a different message makes a new one
(``schemas.make``, ``dataclasses.replace``). The bus enforces what it can cheaply: the arrays of a message that
is shared (published to nodes of this process, or decoded once for several) are made read-only, so an in-place
change raises at once in the node that tries it. A message nobody shares is left as it is: freezing costs 1.6 us
of a hop's 120 (bench/latency.py). With ``PITCHSIDE_CHECK_FROZEN=1`` (the test suite sets it) every message is
frozen, shared or not, so a node that breaks the rule fails alone as it would composed; every in-process delivery
also compares the message's CDR before its first and after its last handler, and a change of any other field is
reported as the node's error.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from dataclasses import fields, is_dataclass
from typing import Any, Protocol

import numpy as np
import zenoh

import schemas
from schemas.codec import Message, SchemaError
from wire import keys


class Subscription(Protocol):
    """What the bus hands messages to: a node's subscription (robot_nodes/runtime/node.py) or a robot's simulated
    clock (clock.py). Declared here so the bus needs neither."""

    robot: str  # whose topic, or keys.ANY_ROBOT
    topic: schemas.Topic

    def hand_over(self, key: str, msg: Message | SchemaError) -> None:
        """From Zenoh: the decoded message, or why it could not be decoded."""
        ...

    def hand_over_cdr(self, key: str, cdr: bytes) -> None:
        """From Zenoh, for a subscriber that decodes itself."""
        ...

    def hand_over_local(self, robot: str, msg: Message, cdr: bytes | None) -> None:
        """From a publisher of this process: the object itself (cdr only to check it stays unchanged)."""
        ...

CHECK_FROZEN_ENV = "PITCHSIDE_CHECK_FROZEN"


class FrozenMessageError(RuntimeError):
    """A node changed a message after it was published (the in-process bus shares one object)."""


THAWED: list[str] = []  # every change to a published message this process found (PITCHSIDE_CHECK_FROZEN=1)


def thawed(what: str) -> FrozenMessageError:
    """Notes a changed message for the tests to find, and the error the node's loop reports."""
    THAWED.append(what)
    return FrozenMessageError(f"{what}: a published message is shared and frozen; make a new one instead")


_PRIMITIVES = ("bool", "int", "float", "str", "bytes", "ClassVar[")
_ARRAY, _MESSAGE, _MESSAGES = 0, 1, 2
_PLANS: dict[type, tuple[tuple[str, int], ...]] = {}  # per message class: the fields that can hold arrays


def _plan(cls: type) -> tuple[tuple[str, int], ...]:
    """What freeze has to visit in a message class, from its field annotations (primitives are skipped)."""
    plan = []
    for f in fields(cls):
        kind = str(f.type)
        if "ndarray" in kind:
            plan.append((f.name, _ARRAY))
        elif kind.startswith("list["):
            if not kind[5:].startswith(_PRIMITIVES):
                plan.append((f.name, _MESSAGES))
        elif not kind.startswith(_PRIMITIVES):
            plan.append((f.name, _MESSAGE))
    return tuple(plan)


def freeze(msg: Any) -> None:
    """Makes the message's arrays read-only, nested messages included (only the fields that can hold arrays)."""
    plan = _PLANS.get(type(msg))
    if plan is None:
        plan = _PLANS[type(msg)] = _plan(type(msg)) if is_dataclass(msg) else ()
    for name, kind in plan:
        value = getattr(msg, name)
        if kind == _ARRAY:
            if isinstance(value, np.ndarray):
                value.flags.writeable = False
        elif kind == _MESSAGE:
            freeze(value)
        else:
            for item in value:
                freeze(item)


class _Inbound:
    """One Zenoh subscriber of the process for one key, shared by every local subscription of that key."""

    def __init__(self, session: zenoh.Session, key: str, msgtype: str, in_order: bool = False) -> None:
        self.msgtype = msgtype
        self.subscriptions: list[Subscription] = []
        # a sample's key is the declared one unless that has a wildcard (robot "*"): not asked of Zenoh then
        self._key = None if "*" in key else key
        handler = zenoh.handlers.Callback(self._on_sample, indirect=not in_order)
        self._zenoh = session.declare_subscriber(key, handler, allowed_origin=zenoh.Locality.REMOTE)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        """On a Zenoh thread: the CDR to a lone subscriber (decoded on its loop, the Zenoh thread is free at
        once), else decoded once here and the object handed to each subscriber's loop."""
        subscriptions = self.subscriptions
        if not subscriptions:
            return
        key = self._key or str(sample.key_expr)
        if len(subscriptions) == 1:
            subscriptions[0].hand_over_cdr(key, sample.payload.to_bytes())
            return
        try:
            msg: Message | SchemaError = schemas.decode(sample.payload.to_bytes(), self.msgtype)
        except SchemaError as exc:
            msg = exc
        else:
            freeze(msg)
        for subscription in subscriptions:
            subscription.hand_over(key, msg)

    def close(self) -> None:
        self._zenoh.undeclare()


class LocalBus:
    """The in-process side of one Zenoh session: who in this process subscribes to what."""

    _of_session: dict[int, LocalBus] = {}
    _registry_lock = threading.Lock()

    def __init__(self, session: zenoh.Session) -> None:
        self.session = session
        self.users = 0
        # False (Zenoh's default): each key's samples are handed over on a thread of its own, Zenoh's network thread
        # is never held by Python. True: on the network thread, in the order they came from a sender; a lockstep
        # simulation sets it before its nodes subscribe (clock.py: a robot's clock_done comes after what it sent)
        self.in_order = False
        self.check_frozen = os.environ.get(CHECK_FROZEN_ENV, "") not in ("", "0")
        self._lock = threading.Lock()
        self._inbound: dict[str, _Inbound] = {}
        # (robot, topic) -> the local subscriptions a message published there reaches; rebuilt on every change,
        # read without a lock by publishers (a new list is swapped in, never changed in place)
        self._local: dict[tuple[str, str], list[Subscription]] = {}
        self._subscriptions: list[Subscription] = []

    # -- the registry: one LocalBus per session --------------------------------------------------------------
    @classmethod
    def join(cls, session: zenoh.Session) -> LocalBus:
        """The session's bus (made on first use); each node that joins leaves again when it closes."""
        with cls._registry_lock:
            bus = cls._of_session.get(id(session))
            if bus is None or bus.session is not session:
                bus = cls._of_session[id(session)] = LocalBus(session)
            bus.users += 1
            return bus

    def leave(self) -> None:
        with self._registry_lock:
            self.users -= 1
            if self.users <= 0 and self._of_session.get(id(self.session)) is self:
                del self._of_session[id(self.session)]

    # -- subscriptions ---------------------------------------------------------------------------------------
    def add(self, subscription: Subscription) -> None:
        key = keys.topic_key(subscription.robot, subscription.topic.name)
        with self._lock:
            inbound = self._inbound.get(key)
            if inbound is None:
                inbound = self._inbound[key] = _Inbound(self.session, key, subscription.topic.type, self.in_order)
            inbound.subscriptions = [*inbound.subscriptions, subscription]
            self._subscriptions.append(subscription)
            self._local = {}

    def remove(self, subscription: Subscription) -> None:
        key = keys.topic_key(subscription.robot, subscription.topic.name)
        with self._lock:
            if subscription in self._subscriptions:
                self._subscriptions.remove(subscription)
            inbound = self._inbound.get(key)
            if inbound is not None:
                inbound.subscriptions = [s for s in inbound.subscriptions if s is not subscription]
                if not inbound.subscriptions:
                    del self._inbound[key]
                    inbound.close()
            self._local = {}

    def local_subscribers(self, robot: str, topic: str) -> list[Subscription]:
        """Who in this process gets what ``robot`` publishes on ``topic`` (cached until subscriptions change)."""
        found = self._local.get((robot, topic))
        if found is None:
            with self._lock:
                found = [s for s in self._subscriptions
                         if s.topic.name == topic and s.robot in (robot, keys.ANY_ROBOT)]
                self._local[(robot, topic)] = found
        return found


class RemoteInterest:
    """Whether a publisher has subscribers outside the process, kept current by Zenoh's matching listener."""

    def __init__(self, publisher: zenoh.Publisher, on_change: Callable[[bool], None] | None = None) -> None:
        self._on_change = on_change
        self._lock = threading.Lock()
        self._told = False  # the listener has reported a change: it knows better than the first read
        self.matching = False
        self._listener = publisher.declare_matching_listener(self._changed)
        # read after the listener is in place, so no change falls between the two; a change the listener reports
        # while this read is on its way is newer than the read, so the read must not overwrite it (a subscriber
        # that appeared then would otherwise never be sent to: no further change comes to correct it)
        first = bool(publisher.matching_status.matching)  # type: ignore[attr-defined]
        with self._lock:
            if not self._told:
                self.matching = first

    def _changed(self, status: Any) -> None:
        matching = bool(status.matching)
        with self._lock:
            self._told = True
            self.matching = matching
        if self._on_change is not None:
            self._on_change(matching)

    def close(self) -> None:
        self._listener.undeclare()
