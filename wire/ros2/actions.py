"""ROS 2's action protocol as rmw_zenoh carries it: an action ``/robot1/animation`` is three services and two topics.

    <action>/_action/send_goal     service  <pkg>/action/<Action>_SendGoal     goal id + goal -> accepted, stamp
    <action>/_action/cancel_goal   service  action_msgs/srv/CancelGoal          goal info -> return code, goals
    <action>/_action/get_result    service  <pkg>/action/<Action>_GetResult    goal id -> status, result (answered
                                                                                 when the goal ends)
    <action>/_action/feedback      topic    <pkg>/action/<Action>_FeedbackMessage   goal id + feedback
    <action>/_action/status        topic    action_msgs/msg/GoalStatusArray     every goal the server knows, latched

rmw_zenoh has no action entities of its own (docs/design.md, "Actions"): these are plain services (queryables) and
topics with their keys, tokens and attachments. A service's type in keys and tokens is its response type's name
without ``Response_`` (rmw_service_data.cpp), so ``<pkg>::action::dds_::<Action>_SendGoal_``. Goal ids are
unique_identifier_msgs/UUID, statuses action_msgs/GoalStatus's codes (design.ros2.org, "Actions"; rcl_action).

This module is pure: names, types, hashes and the CDR of the protocol's own messages. The envelope types
(``X_SendGoal_Request``, ...) are derived from X_Goal, X_Result and X_Feedback the way rosidl does and registered
into the process's typestore on first use, so goals decode into the very classes nodes use.
"""

from __future__ import annotations

import enum
import functools
import threading
from dataclasses import dataclass
from typing import Any

from rosbags.interfaces import Nodetype

from schemas import codec
from schemas.type_hash import with_interface_types
from wire.ros2.errors import Ros2WireError
from wire.ros2.keys import TopicKey, check_name
from wire.ros2.liveliness import Entity, EntityKind, NodeInfo
from wire.ros2.qos import DEFAULT_10, Durability, QoS

GOAL_ID_SIZE = 16
CANCEL_GOAL = "action_msgs/srv/CancelGoal"
GOAL_STATUS_ARRAY = "action_msgs/msg/GoalStatusArray"
_GOAL_INFO = "action_msgs/msg/GoalInfo"
# action_msgs/srv/CancelGoal as Jazzy defines it (rosbags' Jazzy store has action_msgs' messages, not this service)
_CANCEL_DEFS: dict[str, Any] = {
    f"{CANCEL_GOAL}_Request": ([], [("goal_info", (Nodetype.NAME, _GOAL_INFO))]),
    f"{CANCEL_GOAL}_Response": (
        [("ERROR_NONE", "int8", 0), ("ERROR_REJECTED", "int8", 1), ("ERROR_UNKNOWN_GOAL_ID", "int8", 2),
         ("ERROR_GOAL_TERMINATED", "int8", 3)],
        [("return_code", (Nodetype.BASE, ("int8", 0))),
         ("goals_canceling", (Nodetype.SEQUENCE, ((Nodetype.NAME, _GOAL_INFO), 0)))]),
}
_REGISTER = threading.Lock()
# rcl_action's defaults: services as rmw_qos_profile_services_default, feedback as rmw_qos_profile_default, status
# as rcl_action_qos_profile_status_default (latched: a late client learns where its goal stands)
STATUS_QOS = QoS(durability=Durability.TRANSIENT_LOCAL, depth=1)


class GoalStatus(enum.IntEnum):
    """action_msgs/msg/GoalStatus's codes. ROS 2 knows no "preempted": a goal a newer one displaced ends ABORTED."""

    UNKNOWN = 0
    ACCEPTED = 1
    EXECUTING = 2
    CANCELING = 3
    SUCCEEDED = 4
    CANCELED = 5
    ABORTED = 6

    @property
    def terminal(self) -> bool:
        return self >= GoalStatus.SUCCEEDED


class CancelCode(enum.IntEnum):
    """action_msgs/srv/CancelGoal's return codes."""

    NONE = 0
    REJECTED = 1
    UNKNOWN_GOAL_ID = 2
    GOAL_TERMINATED = 3


class Part(enum.Enum):
    """The five parts of an action on the wire, by the name each takes under ``<action>/_action/``."""

    SEND_GOAL = "send_goal"
    CANCEL_GOAL = "cancel_goal"
    GET_RESULT = "get_result"
    FEEDBACK = "feedback"
    STATUS = "status"


@dataclass(frozen=True)
class ActionInterface:
    """One action type (``humanoid_league_msgs/action/PlayAnimation``): the types and hashes of its parts, and the
    CDR of its envelopes. Get it from ``action_interface`` (it registers the envelopes once)."""

    action_type: str

    @property
    def goal_type(self) -> str:
        return f"{self.action_type}_Goal"

    @property
    def result_type(self) -> str:
        return f"{self.action_type}_Result"

    @property
    def feedback_type(self) -> str:
        return f"{self.action_type}_Feedback"

    def part_type(self, part: Part) -> str:
        """The ROS 2 type a part's key and token name (a service's without _Request/_Response)."""
        return {Part.SEND_GOAL: f"{self.action_type}_SendGoal", Part.CANCEL_GOAL: CANCEL_GOAL,
                Part.GET_RESULT: f"{self.action_type}_GetResult",
                Part.FEEDBACK: f"{self.action_type}_FeedbackMessage", Part.STATUS: GOAL_STATUS_ARRAY}[part]

    def key(self, domain_id: int, action_name: str, part: Part) -> TopicKey:
        """The data key of one part of the action ``action_name`` (fully qualified: ``/robot1/animation``)."""
        check_name(action_name)
        part_type = self.part_type(part)
        return TopicKey(domain_id, f"{action_name}/_action/{part.value}", part_type, codec.type_hash(part_type))

    # -- the envelopes ---------------------------------------------------------------------------------
    def send_goal_request(self, goal_id: bytes, goal: Any) -> bytes:
        return _encode(f"{self.action_type}_SendGoal_Request", goal_id=_uuid(goal_id), goal=goal)

    def send_goal_response(self, accepted: bool, stamp_ns: int) -> bytes:
        return _encode(f"{self.action_type}_SendGoal_Response", accepted=accepted, stamp=_time(stamp_ns))

    def get_result_request(self, goal_id: bytes) -> bytes:
        return _encode(f"{self.action_type}_GetResult_Request", goal_id=_uuid(goal_id))

    def get_result_response(self, status: GoalStatus, result: Any) -> bytes:
        return _encode(f"{self.action_type}_GetResult_Response", status=int(status), result=result)

    def feedback_message(self, goal_id: bytes, feedback: Any) -> bytes:
        return _encode(f"{self.action_type}_FeedbackMessage", goal_id=_uuid(goal_id), feedback=feedback)

    def decode(self, envelope: str, data: bytes) -> Any:
        """``envelope`` is one of SendGoal_Request, SendGoal_Response, GetResult_Request, GetResult_Response,
        FeedbackMessage; codec.SchemaError if the bytes are not one."""
        return codec.decode(data, f"{self.action_type}_{envelope}")


def action_interface(action_type: str) -> ActionInterface:
    """The interface of an action type of the typestore (its _Goal, _Result and _Feedback registered). The protocol's
    envelopes go into the store each time (a dict lookup when they are there): the store may be made anew."""
    _register({**_CANCEL_DEFS, **_envelopes(action_type)})
    return ActionInterface(action_type)


@functools.cache
def _envelopes(action_type: str) -> dict[str, Any]:
    """The types ROS 2's action protocol wraps around an action's parts (SendGoal, GetResult, FeedbackMessage)."""
    store = codec.typestore()
    parts = [f"{action_type}_{part}" for part in ("Goal", "Result", "Feedback")]
    missing = [name for name in parts if name not in store.fielddefs]
    if missing:
        raise Ros2WireError(f"action type {action_type!r}: no definition of {', '.join(missing)}")
    derived = with_interface_types({name: store.fielddefs[name] for name in parts})
    return {name: derived[name] for name in derived
            if name.startswith(f"{action_type}_") and name.endswith(
                ("_SendGoal_Request", "_SendGoal_Response", "_GetResult_Request", "_GetResult_Response",
                 "_FeedbackMessage"))}


def _register(defs: dict[str, Any]) -> None:
    store = codec.typestore()
    with _REGISTER:
        new = {name: value for name, value in defs.items() if name not in store.fielddefs}
        if new:
            store.register(new)


def part_entity(zid: str, node: NodeInfo, node_id: int, entity_id: int, interface: ActionInterface,
                action_name: str, part: Part, server: bool) -> Entity:
    """The rmw_zenoh entity of one part of an action server (SS, MP) or client (SC, MS): its token and GID."""
    topic = interface.key(node.domain_id, action_name, part)
    if part in (Part.FEEDBACK, Part.STATUS):
        kind = EntityKind.PUBLISHER if server else EntityKind.SUBSCRIPTION
    else:
        kind = EntityKind.SERVICE if server else EntityKind.CLIENT
    return Entity(zid, node_id, entity_id, kind, node, topic, STATUS_QOS if part is Part.STATUS else DEFAULT_10)


# -- action_msgs ---------------------------------------------------------------------------------------------
def goal_info(goal_id: bytes, stamp_ns: int = 0) -> Any:
    return codec.make(_GOAL_INFO, goal_id=_uuid(goal_id), stamp=_time(stamp_ns))


def cancel_request(goal_id: bytes, stamp_ns: int = 0) -> bytes:
    """Cancel one goal (a zero id with a zero stamp cancels every goal; see CancelGoal.srv)."""
    _register(_CANCEL_DEFS)
    return _encode(f"{CANCEL_GOAL}_Request", goal_info=goal_info(goal_id, stamp_ns))


def cancel_response(code: CancelCode, canceling: list[tuple[bytes, int]]) -> bytes:
    _register(_CANCEL_DEFS)
    return _encode(f"{CANCEL_GOAL}_Response", return_code=int(code),
                   goals_canceling=[goal_info(goal_id, stamp_ns) for goal_id, stamp_ns in canceling])


def decode_cancel(envelope: str, data: bytes) -> Any:
    """``envelope`` Request or Response of CancelGoal; codec.SchemaError if the bytes are not one."""
    _register(_CANCEL_DEFS)
    return codec.decode(data, f"{CANCEL_GOAL}_{envelope}")


def status_array(goals: list[tuple[bytes, int, GoalStatus]]) -> bytes:
    """GoalStatusArray of (goal id, accepted at ns, status)."""
    return _encode(GOAL_STATUS_ARRAY, status_list=[
        codec.make("action_msgs/msg/GoalStatus", goal_info=goal_info(goal_id, stamp_ns), status=int(status))
        for goal_id, stamp_ns, status in goals])


def goal_id_of(uuid: Any) -> bytes:
    """The 16 bytes of a decoded unique_identifier_msgs/UUID."""
    return bytes(uuid.uuid)


def stamp_ns_of(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _uuid(goal_id: bytes) -> Any:
    if len(goal_id) != GOAL_ID_SIZE:
        raise Ros2WireError(f"a goal id is a UUID of {GOAL_ID_SIZE} bytes, not {len(goal_id)}")
    return codec.make("unique_identifier_msgs/msg/UUID", uuid=list(goal_id))


def _time(stamp_ns: int) -> Any:
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    return codec.make("builtin_interfaces/msg/Time", sec=sec, nanosec=nanosec)


def _encode(typename: str, **fields: Any) -> bytes:
    return codec.encode(codec.make(typename, **fields))
