"""Actions over Zenoh, the protocol and the client: goal, feedback, result, cancel and preemption (keys in keys.py).

One goal runs at a time per server. A new goal that the server accepts preempts the active one
(its client gets the status PREEMPTED); the server's ``on_goal`` may reject a goal with a reason,
which the client receives as the verdict of ``send_goal``.
"""

from __future__ import annotations

import enum
import json
import threading
import time
import uuid
from collections.abc import Callable
from typing import Any, Protocol

import zenoh

import schemas
from schemas.codec import Message
from wire import keys

GOAL_ID_BYTES = 16
FEEDBACK = b"F"
RESULT = b"R"


class GoalStatus(enum.IntEnum):
    SUCCEEDED = 0
    CANCELED = 1
    PREEMPTED = 2
    ABORTED = 3


class ActionError(Exception):
    """A goal was rejected or a server did not answer."""


def action_types(action: str) -> tuple[str, str, str]:
    base = schemas.ACTIONS[action].type
    return f"{base}_Goal", f"{base}_Feedback", f"{base}_Result"


class Loop(Protocol):
    """Where a node runs its callbacks (robot_nodes.runtime's event loop): the client hands results to it."""

    def call_soon(self, fn: Callable[..., Any], *args: Any) -> None: ...


class ClientGoal:
    """The client's handle on a sent goal."""

    def __init__(self, client: ActionClient, goal_id: bytes,
                 on_feedback: Callable[[Any], None] | None,
                 on_result: Callable[[GoalStatus, Any], None] | None) -> None:
        self.id = goal_id
        self.accepted: bool | None = None
        self.reason = ""
        self.status: GoalStatus | None = None
        self.result: Any = None
        self.feedback: list[Any] = []
        self._client = client
        self._on_feedback = on_feedback
        self._on_result = on_result
        self._verdict = threading.Event()
        self._done = threading.Event()

    def wait_accepted(self, timeout: float = 5.0) -> bool:
        if not self._verdict.wait(timeout):
            raise ActionError(f"no answer from action server {self._client.action!r} within {timeout} s")
        return bool(self.accepted)

    def wait_result(self, timeout: float = 30.0) -> tuple[GoalStatus, Any]:
        if not self.wait_accepted(timeout):
            raise ActionError(f"goal rejected: {self.reason}")
        if not self._done.wait(timeout):
            raise ActionError(f"goal of {self._client.action!r} not finished within {timeout} s")
        assert self.status is not None
        return self.status, self.result

    @property
    def done(self) -> bool:
        return self._done.is_set()

    def cancel(self, timeout: float = 5.0) -> bool:
        """Blocks until the server answers (True: it cancels). Never from a node's loop: the server may be a node of
        the same loop, which then answers only after the timeout (request_cancel)."""
        return self._client._cancel(self.id, timeout)

    def request_cancel(self, on_answer: Callable[[bool], None] | None = None, timeout: float = 2.0) -> None:
        """Asks the server to cancel and returns at once; ``on_answer(accepted)`` runs on the client's loop. From a
        node's loop this is the way: a blocking cancel of a goal served on the same loop held the loop for its whole
        timeout (200 ms of a simulated match's world waiting on a striker whose kick the game stopped)."""
        self._client._request_cancel(self.id, on_answer, timeout)


class ActionClient:
    """Sends goals to one robot's action server. Callbacks run on ``loop`` if given, else on Zenoh threads."""

    def __init__(self, session: zenoh.Session, robot: str, action: str, loop: Loop | None = None) -> None:
        self.action = action
        self.robot = robot
        self.goal_type, self.feedback_type, self.result_type = action_types(action)
        self._session = session
        self._loop = loop
        self._goals: dict[bytes, ClientGoal] = {}
        self._lock = threading.Lock()
        self._subs = [session.declare_subscriber(keys.action_key(robot, action, "events"), self._on_event)]

    def _dispatch(self, fn: Callable[..., None] | None, *args: Any) -> None:
        if fn is None:
            return
        if self._loop is not None:
            self._loop.call_soon(fn, *args)
        else:
            fn(*args)

    def send_goal(self, goal: Message, on_feedback: Callable[[Any], None] | None = None,
                  on_result: Callable[[GoalStatus, Any], None] | None = None,
                  on_verdict: Callable[[ClientGoal], None] | None = None, timeout: float = 5.0) -> ClientGoal:
        """Non-blocking: returns at once; wait on the handle or pass callbacks."""
        goal_id = uuid.uuid4().bytes
        handle = ClientGoal(self, goal_id, on_feedback, on_result)
        with self._lock:
            self._goals[goal_id] = handle
        payload = goal_id + schemas.encode(goal)
        deadline = time.monotonic() + timeout

        def on_done() -> None:
            # no server answered: it may not be routed to us yet, so ask again until the timeout
            if handle._verdict.is_set():
                return
            if time.monotonic() < deadline:
                threading.Timer(0.05, ask).start()
            else:
                handle.accepted = False
                handle.reason = f"no action server {self.action!r} for robot {self.robot!r}"
                with self._lock:
                    self._goals.pop(goal_id, None)
                handle._verdict.set()
                self._dispatch(on_verdict, handle)

        def ask() -> None:
            self._session.get(keys.action_key(self.robot, self.action, "goal"),
                              zenoh.handlers.Callback(on_reply, on_done), payload=payload,
                              timeout=max(0.05, deadline - time.monotonic()))

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None:
                verdict = json.loads(reply.ok.payload.to_bytes())
                handle.accepted = bool(verdict.get("accepted"))
                handle.reason = verdict.get("reason", "")
            else:
                handle.accepted = False
                handle.reason = reply.err.payload.to_string() if reply.err is not None else "error"
            if not handle.accepted:
                with self._lock:
                    self._goals.pop(goal_id, None)
            handle._verdict.set()
            self._dispatch(on_verdict, handle)

        ask()
        return handle

    def _cancel(self, goal_id: bytes, timeout: float) -> bool:
        replies = self._session.get(keys.action_key(self.robot, self.action, "cancel"), payload=goal_id,
                                    timeout=timeout)
        for reply in replies:
            if reply.ok is not None:
                return bool(json.loads(reply.ok.payload.to_bytes()).get("accepted"))
        return False

    def _request_cancel(self, goal_id: bytes, on_answer: Callable[[bool], None] | None, timeout: float) -> None:
        answered = threading.Event()

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None and not answered.is_set():
                answered.set()
                self._dispatch(on_answer, bool(json.loads(reply.ok.payload.to_bytes()).get("accepted")))

        def on_done() -> None:
            if not answered.is_set():
                self._dispatch(on_answer, False)

        self._session.get(keys.action_key(self.robot, self.action, "cancel"),
                          zenoh.handlers.Callback(on_reply, on_done), payload=goal_id, timeout=timeout)

    def _on_event(self, sample: zenoh.Sample) -> None:
        data = sample.payload.to_bytes()
        kind = data[GOAL_ID_BYTES:GOAL_ID_BYTES + 1]
        if kind == FEEDBACK:
            self._on_feedback(data)
        elif kind == RESULT:
            self._on_result(data)

    def _on_feedback(self, data: bytes) -> None:
        handle = self._goals.get(data[:GOAL_ID_BYTES])
        if handle is None:
            return
        try:
            feedback = schemas.decode(data[GOAL_ID_BYTES + 1:], self.feedback_type)
        except schemas.SchemaError:
            return
        handle.feedback.append(feedback)
        self._dispatch(handle._on_feedback, feedback)

    def _on_result(self, data: bytes) -> None:
        with self._lock:
            handle = self._goals.pop(data[:GOAL_ID_BYTES], None)
        if handle is None or len(data) < GOAL_ID_BYTES + 2:
            return
        handle.status = GoalStatus(data[GOAL_ID_BYTES + 1])
        try:
            handle.result = schemas.decode(data[GOAL_ID_BYTES + 2:], self.result_type)
        except schemas.SchemaError:
            handle.result = None
        handle._done.set()
        self._dispatch(handle._on_result, handle.status, handle.result)

    def close(self) -> None:
        for sub in self._subs:
            sub.undeclare()
