"""Actions over Zenoh: goal, feedback, result, cancel and preemption (keys in keys.py).

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
from typing import TYPE_CHECKING, Any

import zenoh

import schemas
from robot_nodes.runtime import keys

if TYPE_CHECKING:
    from robot_nodes.runtime.loop import EventLoop

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


def _types(action: str) -> tuple[str, str, str]:
    base = schemas.ACTIONS[action].type
    return f"{base}_Goal", f"{base}_Feedback", f"{base}_Result"


class ServerGoal:
    """The server's handle on one goal: publish feedback, then end it exactly once."""

    def __init__(self, server: ActionServer, goal_id: bytes, goal: Any) -> None:
        self.id = goal_id
        self.goal = goal
        self.cancel_requested = False
        self.done = False
        self._server = server

    def publish_feedback(self, feedback: Any) -> None:
        if not self.done:
            self._server._events.put(self.id + FEEDBACK + schemas.encode(feedback))

    def succeed(self, result: Any) -> None:
        self._end(GoalStatus.SUCCEEDED, result)

    def abort(self, result: Any) -> None:
        self._end(GoalStatus.ABORTED, result)

    def canceled(self, result: Any) -> None:
        self._end(GoalStatus.CANCELED, result)

    def _end(self, status: GoalStatus, result: Any) -> None:
        if self.done:
            return
        self.done = True
        self._server._events.put(self.id + RESULT + bytes([status]) + schemas.encode(result))
        if self._server.active is self:
            self._server.active = None


class ActionServer:
    """Serves one action of the table; callbacks run on the node's loop."""

    def __init__(
        self,
        session: zenoh.Session,
        loop: EventLoop,
        robot: str,
        action: str,
        on_goal: Callable[[ServerGoal], str | None],
        on_cancel: Callable[[ServerGoal], None] | None = None,
        on_preempt: Callable[[ServerGoal], None] | None = None,
    ) -> None:
        self.action = action
        self.goal_type, self.feedback_type, self.result_type = _types(action)
        self.active: ServerGoal | None = None
        self._on_goal = on_goal
        self._on_cancel = on_cancel
        self._on_preempt = on_preempt
        self._loop = loop
        self._events = session.declare_publisher(keys.action_key(robot, action, "events"))
        self._goal_q = session.declare_queryable(
            keys.action_key(robot, action, "goal"), lambda q: loop.call_soon(self._handle_goal, q)
        )
        self._cancel_q = session.declare_queryable(
            keys.action_key(robot, action, "cancel"), lambda q: loop.call_soon(self._handle_cancel, q)
        )
        self._robot = robot

    def empty_result(self) -> Any:
        return schemas.make(self.result_type)

    def _reply(self, query: zenoh.Query, part: str, verdict: dict[str, Any]) -> None:
        query.reply(keys.action_key(self._robot, self.action, part), json.dumps(verdict))
        query.drop()

    def _handle_goal(self, query: zenoh.Query) -> None:
        payload = query.payload.to_bytes() if query.payload is not None else b""
        if len(payload) < GOAL_ID_BYTES:
            self._reply(query, "goal", {"accepted": False, "reason": "goal request without goal id"})
            return
        goal_id = payload[:GOAL_ID_BYTES]
        try:
            goal = schemas.decode(payload[GOAL_ID_BYTES:], self.goal_type)
        except schemas.SchemaError as exc:
            self._reply(query, "goal", {"accepted": False, "reason": str(exc)})
            return
        handle = ServerGoal(self, goal_id, goal)
        try:
            reason = self._on_goal(handle)
        except Exception as exc:
            reason = f"{type(exc).__name__}: {exc}"
        if reason:
            self._reply(query, "goal", {"accepted": False, "reason": reason})
            return
        previous = self.active
        if previous is not None and not previous.done:
            if self._on_preempt is not None:
                self._on_preempt(previous)
            previous._end(GoalStatus.PREEMPTED, self.empty_result())
        self.active = handle
        self._reply(query, "goal", {"accepted": True, "reason": ""})

    def _handle_cancel(self, query: zenoh.Query) -> None:
        goal_id = query.payload.to_bytes() if query.payload is not None else b""
        active = self.active
        if active is None or active.id != goal_id or active.done:
            self._reply(query, "cancel", {"accepted": False, "reason": "no such active goal"})
            return
        active.cancel_requested = True
        if self._on_cancel is not None:
            self._on_cancel(active)
        else:
            active.canceled(self.empty_result())
        self._reply(query, "cancel", {"accepted": True, "reason": ""})

    def close(self) -> None:
        for item in (self._goal_q, self._cancel_q, self._events):
            item.undeclare()


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
        return self._client._cancel(self.id, timeout)


class ActionClient:
    """Sends goals to one robot's action server. Callbacks run on ``loop`` if given, else on Zenoh threads."""

    def __init__(self, session: zenoh.Session, robot: str, action: str, loop: EventLoop | None = None) -> None:
        self.action = action
        self.robot = robot
        self.goal_type, self.feedback_type, self.result_type = _types(action)
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

    def send_goal(self, goal: Any, on_feedback: Callable[[Any], None] | None = None,
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
