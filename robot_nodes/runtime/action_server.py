"""The action server of a node: one goal at a time, a new accepted goal preempts the active one (wire.actions)."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import zenoh

import schemas
from schemas.codec import Message
from wire import keys
from wire.actions import FEEDBACK, GOAL_ID_BYTES, RESULT, GoalStatus, action_types

if TYPE_CHECKING:
    from robot_nodes.runtime.loop import EventLoop


class ServerGoal:
    """The server's handle on one goal: publish feedback, then end it exactly once."""

    def __init__(self, server: ActionServer, goal_id: bytes, goal: Any) -> None:  # Any: the action's own goal class
        self.id = goal_id
        self.goal = goal
        self.cancel_requested = False
        self.done = False
        self._server = server

    def publish_feedback(self, feedback: Message) -> None:
        if not self.done:
            self._server._events.put(self.id + FEEDBACK + schemas.encode(feedback))

    def succeed(self, result: Message) -> None:
        self._end(GoalStatus.SUCCEEDED, result)

    def abort(self, result: Message) -> None:
        self._end(GoalStatus.ABORTED, result)

    def canceled(self, result: Message) -> None:
        self._end(GoalStatus.CANCELED, result)

    def _end(self, status: GoalStatus, result: Message) -> None:
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
        self.goal_type, self.feedback_type, self.result_type = action_types(action)
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

    def empty_result(self) -> Message:
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
