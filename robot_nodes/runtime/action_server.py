"""The action server of a node, on ROS 2's action protocol (wire/ros2/actions.py): one goal runs at a time, and a
new accepted goal preempts the running one, which ends ABORTED (ROS 2 has no "preempted").

Requests arrive on Zenoh threads and are decided on the node's loop, so node code needs no locks. get_result is
answered when its goal ends; a goal that already ended is kept (its status and result) for late askers, the last
KEPT_GOALS of them for at most RESULT_KEEP_S, as rcl_action keeps results for its result timeout.

A rejected goal's reason goes to the node's log (and so to /rosout), and, where the result type has a ``message``
field, into the result that get_result gives for that goal id with the status UNKNOWN: ROS 2's send_goal answer
carries no reason, and a ROS 2 client never asks for the result of a rejected goal, so this adds to the protocol
without changing it. pitchside's client asks, so its user hears why.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import zenoh

import schemas
from schemas.codec import Message, SchemaError
from wire.ros2.actions import (
    GOAL_ID_SIZE,
    CancelCode,
    GoalStatus,
    Part,
    action_interface,
    cancel_response,
    decode_cancel,
    goal_id_of,
    part_entity,
    stamp_ns_of,
    status_array,
)
from wire.ros2.endpoints import Ros2Publisher
from wire.ros2.liveliness import NodeInfo
from wire.ros2.requests import PendingRequest, RequestServer

if TYPE_CHECKING:
    from robot_nodes.runtime.loop import EventLoop

KEPT_GOALS = 32
RESULT_KEEP_S = 900.0  # rcl_action's default result timeout (15 min)
REJECTIONS_KEPT = 32  # reasons of recent rejections, for get_result
_CDR_HEADER = 4


class ServerGoal:
    """The server's handle on one goal: publish feedback, then end it exactly once."""

    def __init__(self, server: ActionServer, goal_id: bytes, goal: Any) -> None:  # Any: the action's own goal class
        self.id = goal_id
        self.goal = goal
        self.cancel_requested = False
        self.done = False
        self.status = GoalStatus.EXECUTING
        self.result: Any = None
        self.accepted_ns = time.time_ns()
        self.ended_at = 0.0
        self._server = server
        self._result_requests: list[PendingRequest] = []

    def publish_feedback(self, feedback: Message) -> None:
        if not self.done:
            self._server._feedback.publish(self._server.interface.feedback_message(self.id, feedback))

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
        self.status, self.result, self.ended_at = status, result, time.monotonic()
        if self._server.active is self:
            self._server.active = None
        self._server._publish_status()
        answer = self._server.interface.get_result_response(status, result)
        for request in self._result_requests:
            request.reply(answer)
        self._result_requests.clear()


class ActionServer:
    """Serves one action of the table as ``/<robot>/<action>``; callbacks run on the node's loop.

    Counted (and shown in the node's diagnostics by its caller): ``bad_requests`` that did not decode,
    ``unknown_goals`` asked about in get_result or cancel_goal; requests without rmw_zenoh's attachment are
    dropped by the services (``dropped``)."""

    def __init__(
        self,
        session: zenoh.Session,
        loop: EventLoop,
        robot: str,
        action: str,
        on_goal: Callable[[ServerGoal], str | None],
        on_cancel: Callable[[ServerGoal], None] | None = None,
        on_preempt: Callable[[ServerGoal], None] | None = None,
        *,
        node: NodeInfo,
        node_id: int,
        entity_ids: Callable[[], int],
        log: Callable[[str], None] | None = None,
        diagnostic: Callable[[str, Any], None] | None = None,
    ) -> None:
        self.action = action
        self.interface = action_interface(schemas.ACTIONS[action].type)
        self.goal_type = self.interface.goal_type
        self.feedback_type = self.interface.feedback_type
        self.result_type = self.interface.result_type
        self.name = f"{node.namespace.rstrip('/')}/{action}"  # the ROS 2 action name: /robot1/animation
        self.active: ServerGoal | None = None
        self.goals: OrderedDict[bytes, ServerGoal] = OrderedDict()
        self.rejected: OrderedDict[bytes, str] = OrderedDict()
        self.bad_requests = 0
        self.unknown_goals = 0
        self._on_goal = on_goal
        self._on_cancel = on_cancel
        self._on_preempt = on_preempt
        self._loop = loop
        self._log = log or (lambda text: None)
        self._diagnostic = diagnostic or (lambda key, value: None)
        zid = str(session.zid())

        def entity(part: Part) -> Any:
            return part_entity(zid, node, node_id, entity_ids(), self.interface, self.name, part, server=True)

        def on_loop(handler: Callable[[PendingRequest], None]) -> Callable[[PendingRequest], None]:
            return lambda request: loop.call_soon(handler, request)

        self._services = [
            RequestServer(session, entity(Part.SEND_GOAL), on_loop(self._handle_goal)),
            RequestServer(session, entity(Part.CANCEL_GOAL), on_loop(self._handle_cancel)),
            RequestServer(session, entity(Part.GET_RESULT), on_loop(self._handle_get_result)),
        ]
        self._feedback = Ros2Publisher(session, entity(Part.FEEDBACK))
        self._status = Ros2Publisher(session, entity(Part.STATUS))

    @property
    def dropped(self) -> int:
        """Requests without a valid attachment (rmw_zenoh would drop them too)."""
        return sum(service.dropped for service in self._services)

    def empty_result(self) -> Message:
        return schemas.make(self.result_type)

    def rejection_result(self, reason: str) -> Message:
        """The result get_result gives for a rejected goal: the reason in ``message`` where the type has one."""
        result = self.empty_result()
        if isinstance(getattr(result, "message", None), str):
            result.message = reason  # type: ignore[attr-defined]  # a field of the action's own result class
        return result

    # -- send_goal ------------------------------------------------------------------------------------------
    def _handle_goal(self, request: PendingRequest) -> None:
        payload = request.payload
        goal_id = payload[_CDR_HEADER:_CDR_HEADER + GOAL_ID_SIZE]
        try:
            envelope = self.interface.decode("SendGoal_Request", payload)
            goal_id = goal_id_of(envelope.goal_id)
        except SchemaError as exc:
            self._count_bad()
            readable_id = goal_id if len(goal_id) == GOAL_ID_SIZE else b""
            self._reject(request, readable_id, f"a goal that does not decode: {exc}")
            return
        if goal_id in self.goals:
            self._reject(request, b"", "a goal with this id exists already")
            return
        handle = ServerGoal(self, goal_id, envelope.goal)
        try:
            reason = self._on_goal(handle)
        except Exception as exc:
            reason = f"{type(exc).__name__}: {exc}"
        if reason:
            self._reject(request, goal_id, reason)
            return
        previous = self.active
        if previous is not None and not previous.done:
            if self._on_preempt is not None:
                self._on_preempt(previous)
            previous._end(GoalStatus.ABORTED, self.empty_result())
        self.active = handle
        self._keep(handle)
        self._publish_status()
        request.reply(self.interface.send_goal_response(True, handle.accepted_ns))

    def _reject(self, request: PendingRequest, goal_id: bytes, reason: str) -> None:
        self._log(f"{self.name}: goal rejected: {reason}")
        if goal_id:
            self.rejected[goal_id] = reason
            while len(self.rejected) > REJECTIONS_KEPT:
                self.rejected.popitem(last=False)
        request.reply(self.interface.send_goal_response(False, 0))

    def _keep(self, handle: ServerGoal) -> None:
        self.goals[handle.id] = handle
        now = time.monotonic()
        for goal_id, goal in list(self.goals.items()):
            too_many = len(self.goals) > KEPT_GOALS
            if goal.done and (too_many or now - goal.ended_at > RESULT_KEEP_S):
                del self.goals[goal_id]

    # -- cancel_goal ----------------------------------------------------------------------------------------
    def _handle_cancel(self, request: PendingRequest) -> None:
        try:
            info = decode_cancel("Request", request.payload).goal_info
        except SchemaError as exc:
            self._count_bad()
            self._log(f"{self.name}: a cancel request that does not decode: {exc}")
            request.reply(cancel_response(CancelCode.REJECTED, []))
            return
        goal_id, stamp_ns = goal_id_of(info.goal_id), stamp_ns_of(info.stamp)
        any_goal = goal_id == bytes(GOAL_ID_SIZE)
        # CancelGoal.srv: a zero id cancels all goals (accepted at or before stamp, if given); an id cancels it
        chosen = [goal for goal in self.goals.values()
                  if (not any_goal and goal.id == goal_id) or ((any_goal or stamp_ns) and
                                                               (not stamp_ns or goal.accepted_ns <= stamp_ns))]
        cancelable = [goal for goal in chosen if not goal.done]
        if not cancelable:
            if not any_goal and goal_id not in self.goals:
                self._count_unknown()
                code = CancelCode.UNKNOWN_GOAL_ID
            elif not any_goal:
                code = CancelCode.GOAL_TERMINATED
            else:
                code = CancelCode.REJECTED
            request.reply(cancel_response(code, []))
            return
        for goal in cancelable:
            goal.cancel_requested = True
            goal.status = GoalStatus.CANCELING
        self._publish_status()
        request.reply(cancel_response(CancelCode.NONE, [(goal.id, goal.accepted_ns) for goal in cancelable]))
        for goal in cancelable:
            if self._on_cancel is not None:
                self._on_cancel(goal)
            else:
                goal.canceled(self.empty_result())

    # -- get_result -----------------------------------------------------------------------------------------
    def _handle_get_result(self, request: PendingRequest) -> None:
        try:
            goal_id = goal_id_of(self.interface.decode("GetResult_Request", request.payload).goal_id)
        except SchemaError as exc:
            self._count_bad()
            self._log(f"{self.name}: a get_result request that does not decode: {exc}")
            request.reply(self.interface.get_result_response(GoalStatus.UNKNOWN, self.empty_result()))
            return
        goal = self.goals.get(goal_id)
        if goal is None:
            reason = self.rejected.get(goal_id)
            if reason is None:
                self._count_unknown()
            result = self.rejection_result(reason) if reason is not None else self.empty_result()
            request.reply(self.interface.get_result_response(GoalStatus.UNKNOWN, result))
        elif goal.done:
            request.reply(self.interface.get_result_response(goal.status, goal.result))
        else:
            goal._result_requests.append(request)

    def _count_bad(self) -> None:
        self.bad_requests += 1
        self._diagnostic(f"{self.action}/bad_requests", self.bad_requests)

    def _count_unknown(self) -> None:
        self.unknown_goals += 1
        self._diagnostic(f"{self.action}/unknown_goals", self.unknown_goals)

    def _publish_status(self) -> None:
        self._status.publish(status_array([(goal.id, goal.accepted_ns, goal.status) for goal in self.goals.values()]))

    def close(self) -> None:
        for goal in self.goals.values():
            for request in goal._result_requests:
                request.reply_error(f"{self.name}: the action server closed")
        for service in self._services:
            service.close()
        self._feedback.close()
        self._status.close()
