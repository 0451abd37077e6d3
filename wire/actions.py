"""pitchside's action client on ROS 2's action protocol (wire/ros2/actions.py): goal, feedback, result, cancel.

A goal goes to ``<action>/_action/send_goal``; once accepted, the client asks ``get_result``, which the server
answers when the goal ends, and follows ``feedback`` and ``status``, as rclpy's ActionClient does. So the server
may be a pitchside node or any ROS 2 action server of the same type, and a ROS 2 client may use pitchside's.

One goal runs at a time on pitchside's servers: a new accepted goal preempts the running one, which ends ABORTED.
ROS 2's send_goal answer says only accepted or not; after a rejection the client asks get_result for the reason
(pitchside's servers put it in the result's ``message``; robot_nodes/runtime/action_server.py), so ``reason`` says
why where the server tells, and "rejected by <action>" where it does not.
"""

from __future__ import annotations

import threading
import time
import uuid
from collections import OrderedDict
from collections.abc import Callable
from typing import Any, Protocol

import zenoh

import schemas
from schemas.codec import Message, SchemaError
from wire.ros2 import robots as ros2_robots
from wire.ros2.actions import (
    CancelCode,
    GoalStatus,
    Part,
    action_interface,
    cancel_request,
    decode_cancel,
    goal_id_of,
    part_entity,
)
from wire.ros2.attachment import Attachment
from wire.ros2.endpoints import Ros2Subscription
from wire.ros2.keys import domain_id_from_env
from wire.ros2.liveliness import NodeInfo
from wire.ros2.requests import RequestClient

__all__ = ["ActionClient", "ActionError", "ClientGoal", "GoalStatus", "action_types"]

RESULT_TIMEOUT_S = 24 * 3600.0  # get_result waits for the goal's end (rmw_zenoh waits without limit)
RETRY_PERIOD_S = 0.05  # asking again for a server not routed to us yet
ENDED_KEPT = 16  # ended goals whose late feedback is still recorded


class ActionError(Exception):
    """A goal was rejected or a server did not answer."""


def action_types(action: str) -> tuple[str, str, str]:
    """Goal, feedback and result type of an action of the table."""
    interface = action_interface(schemas.ACTIONS[action].type)
    return interface.goal_type, interface.feedback_type, interface.result_type


class Loop(Protocol):
    """Where a node runs its callbacks (robot_nodes.runtime's event loop): the client hands results to it."""

    def call_soon(self, fn: Callable[..., Any], *args: Any) -> None: ...


class ClientGoal:
    """The client's handle on a sent goal. ``status`` is its end (SUCCEEDED, CANCELED, ABORTED; UNKNOWN when the
    server forgot it or went away), ``live_status`` what the server's status topic last said."""

    def __init__(self, client: ActionClient, goal_id: bytes,
                 on_feedback: Callable[[Any], None] | None,
                 on_result: Callable[[GoalStatus, Any], None] | None) -> None:
        self.id = goal_id
        self.accepted: bool | None = None
        self.reason = ""
        self.status: GoalStatus | None = None
        self.live_status: GoalStatus | None = None
        self.result: Any = None
        self.feedback: list[Any] = []
        self._client = client
        self._on_feedback = on_feedback
        self._on_result = on_result
        self._verdict = threading.Event()
        self._done = threading.Event()

    def wait_accepted(self, timeout: float = 5.0) -> bool:
        if not self._verdict.wait(timeout):
            raise ActionError(f"no answer from action server {self._client.name!r} within {timeout} s")
        return bool(self.accepted)

    def wait_result(self, timeout: float = 30.0) -> tuple[GoalStatus, Any]:
        if not self.wait_accepted(timeout):
            raise ActionError(f"goal rejected: {self.reason}")
        if not self._done.wait(timeout):
            raise ActionError(f"goal of {self._client.name!r} not finished within {timeout} s")
        assert self.status is not None
        return self.status, self.result

    @property
    def done(self) -> bool:
        return self._done.is_set()

    def cancel(self, timeout: float = 5.0) -> bool:
        """Blocks until the server answers (True: it cancels). Never from a node's loop: the server may be a node of
        the same loop, which then answers only after the timeout (request_cancel)."""
        answer = threading.Event()
        outcome: list[bool] = []

        def on_answer(accepted: bool) -> None:
            outcome.append(accepted)
            answer.set()

        self._client._request_cancel(self.id, on_answer, timeout, dispatch=False)
        answer.wait(timeout + 1.0)
        return bool(outcome and outcome[0])

    def request_cancel(self, on_answer: Callable[[bool], None] | None = None, timeout: float = 2.0) -> None:
        """Asks the server to cancel and returns at once; ``on_answer(accepted)`` runs on the client's loop. From a
        node's loop this is the way: a blocking cancel of a goal served on the same loop held the loop for its whole
        timeout (200 ms of a simulated match's world waiting on a striker whose kick the game stopped)."""
        self._client._request_cancel(self.id, on_answer, timeout)


class ActionClient:
    """Sends goals to one robot's action ``/<robot>/<action>``. Callbacks run on ``loop`` if given, else on Zenoh
    threads. ``node`` names the ROS 2 node the client belongs to on the graph (its tokens); without one (a
    script, a test) the client's tokens name ``/<robot>/pitchside_client``."""

    def __init__(self, session: zenoh.Session, robot: str, action: str, loop: Loop | None = None, *,
                 node: NodeInfo | None = None, node_id: int | None = None,
                 entity_ids: Callable[[], int] | None = None, domain_id: int | None = None) -> None:
        self.action = action
        self.robot = robot
        self.interface = action_interface(schemas.ACTIONS[action].type)
        self.goal_type = self.interface.goal_type
        self.feedback_type = self.interface.feedback_type
        self.result_type = self.interface.result_type
        domain = domain_id_from_env() if domain_id is None else domain_id
        self.name = f"{ros2_robots.robot_namespace(robot)}/{action}"
        if node is None:
            node = NodeInfo(domain, ros2_robots.robot_namespace(robot), "pitchside_client")
        if node_id is None:
            node_id = ros2_robots.next_node_id()
        if entity_ids is None:
            counter = iter(range(node_id + 1, node_id + 1_000_000))
            entity_ids = counter.__next__
        zid = str(session.zid())
        self._session = session
        self._loop = loop
        self._goals: dict[bytes, ClientGoal] = {}
        # goals that ended lately: feedback and result travel apart, so a last feedback may come after the result
        self._ended: OrderedDict[bytes, ClientGoal] = OrderedDict()
        self._lock = threading.Lock()

        def entity(part: Part) -> Any:
            return part_entity(zid, node, node_id, entity_ids(), self.interface, self.name, part, server=False)

        self._send_goal = RequestClient(session, entity(Part.SEND_GOAL))
        self._cancel_goal = RequestClient(session, entity(Part.CANCEL_GOAL))
        self._get_result = RequestClient(session, entity(Part.GET_RESULT))
        self._feedback = Ros2Subscription(session, entity(Part.FEEDBACK), self._on_feedback_sample)
        self._status = Ros2Subscription(session, entity(Part.STATUS), self._on_status_sample)
        self.bad_replies = 0  # replies and samples that did not decode

    def _dispatch(self, fn: Callable[..., None] | None, *args: Any) -> None:
        if fn is None:
            return
        if self._loop is not None:
            self._loop.call_soon(fn, *args)
        else:
            fn(*args)

    # -- goals ----------------------------------------------------------------------------------------------
    def send_goal(self, goal: Message, on_feedback: Callable[[Any], None] | None = None,
                  on_result: Callable[[GoalStatus, Any], None] | None = None,
                  on_verdict: Callable[[ClientGoal], None] | None = None, timeout: float = 5.0) -> ClientGoal:
        """Non-blocking: returns at once; wait on the handle or pass callbacks."""
        goal_id = uuid.uuid4().bytes
        handle = ClientGoal(self, goal_id, on_feedback, on_result)
        with self._lock:
            self._goals[goal_id] = handle
        request = self.interface.send_goal_request(goal_id, goal)
        deadline = time.monotonic() + timeout

        def verdict(accepted: bool, reason: str) -> None:
            handle.accepted, handle.reason = accepted, reason
            if not accepted:
                with self._lock:
                    self._goals.pop(goal_id, None)
            handle._verdict.set()
            self._dispatch(on_verdict, handle)

        def on_reply(cdr: bytes) -> None:
            try:
                accepted = bool(self.interface.decode("SendGoal_Response", cdr).accepted)
            except SchemaError as exc:
                self.bad_replies += 1
                verdict(False, f"{self.name}: an answer that does not decode: {exc}")
                return
            if accepted:
                if handle.live_status is None:  # the status topic may have told more already
                    handle.live_status = GoalStatus.ACCEPTED
                verdict(True, "")
                self._ask_result(handle)
            else:
                self._ask_reason(handle, verdict)

        def on_fail(why: str, heard: bool) -> None:
            if not heard and time.monotonic() < deadline:  # not routed to us yet: ask again until the timeout
                threading.Timer(RETRY_PERIOD_S, ask).start()
            elif not heard:
                verdict(False, f"no action server {self.name} answered within {timeout} s")
            else:
                verdict(False, why)

        def ask() -> None:
            self._send_goal.ask(request, on_reply, on_fail, max(RETRY_PERIOD_S, deadline - time.monotonic()))

        ask()
        return handle

    def _ask_reason(self, handle: ClientGoal, verdict: Callable[[bool, str], None]) -> None:
        """After a rejection: the reason, where the server keeps one (pitchside's do, ROS 2's do not)."""
        plain = f"rejected by {self.name}"

        def on_reply(cdr: bytes) -> None:
            try:
                message = getattr(self.interface.decode("GetResult_Response", cdr).result, "message", "")
            except SchemaError:
                message = ""
            verdict(False, message if isinstance(message, str) and message else plain)

        self._get_result.ask(self.interface.get_result_request(handle.id), on_reply,
                             lambda _why, _heard: verdict(False, plain), 2.0)

    def _ask_result(self, handle: ClientGoal) -> None:
        def on_reply(cdr: bytes) -> None:
            try:
                answer = self.interface.decode("GetResult_Response", cdr)
                status, result = GoalStatus(answer.status), answer.result
            except (SchemaError, ValueError):
                self.bad_replies += 1
                status, result = GoalStatus.UNKNOWN, None
            self._finish(handle, status, result)

        def on_fail(_why: str, _heard: bool) -> None:
            self._finish(handle, GoalStatus.UNKNOWN, None)  # the server went away: the goal's end is unknown

        self._get_result.ask(self.interface.get_result_request(handle.id), on_reply, on_fail, RESULT_TIMEOUT_S)

    def _finish(self, handle: ClientGoal, status: GoalStatus, result: Any) -> None:
        with self._lock:
            if self._goals.pop(handle.id, None) is None:
                return
            self._ended[handle.id] = handle
            while len(self._ended) > ENDED_KEPT:
                self._ended.popitem(last=False)
        handle.status, handle.result, handle.live_status = status, result, status
        handle._done.set()
        self._dispatch(handle._on_result, status, result)

    # -- cancel ---------------------------------------------------------------------------------------------
    def _request_cancel(self, goal_id: bytes, on_answer: Callable[[bool], None] | None, timeout: float,
                        dispatch: bool = True) -> None:
        def answer(accepted: bool) -> None:
            if dispatch:
                self._dispatch(on_answer, accepted)
            elif on_answer is not None:
                on_answer(accepted)

        def on_reply(cdr: bytes) -> None:
            try:
                response = decode_cancel("Response", cdr)
            except SchemaError:
                self.bad_replies += 1
                answer(False)
                return
            canceling = {goal_id_of(info.goal_id) for info in response.goals_canceling}
            answer(response.return_code == CancelCode.NONE and goal_id in canceling)

        self._cancel_goal.ask(cancel_request(goal_id), on_reply, lambda _why, _heard: answer(False), timeout)

    # -- feedback and status --------------------------------------------------------------------------------
    def _on_feedback_sample(self, cdr: bytes, _attachment: Attachment) -> None:
        try:
            message = self.interface.decode("FeedbackMessage", cdr)
        except SchemaError:
            self.bad_replies += 1
            return
        goal_id = goal_id_of(message.goal_id)
        handle = self._goals.get(goal_id)
        if handle is None:
            late = self._ended.get(goal_id)
            if late is not None:  # kept in the goal's record, but no callback after the result
                late.feedback.append(message.feedback)
            return
        handle.feedback.append(message.feedback)
        self._dispatch(handle._on_feedback, message.feedback)

    def _on_status_sample(self, cdr: bytes, _attachment: Attachment) -> None:
        try:
            statuses = schemas.decode(cdr, "action_msgs/msg/GoalStatusArray").status_list
        except SchemaError:
            self.bad_replies += 1
            return
        for entry in statuses:
            handle = self._goals.get(goal_id_of(entry.goal_info.goal_id))
            if handle is not None and not handle.done:
                try:
                    handle.live_status = GoalStatus(entry.status)
                except ValueError:
                    self.bad_replies += 1

    def close(self) -> None:
        for entity in (self._send_goal, self._cancel_goal, self._get_result, self._feedback, self._status):
            entity.close()
