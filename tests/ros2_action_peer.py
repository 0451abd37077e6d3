"""A ROS 2 action client and server for PlayAnimation, written for the tests from ROS 2's action protocol
(design.ros2.org "Actions", action_msgs, rcl_action) on rmw_zenoh's wire (docs/design.md of 0.2.x), with raw Zenoh
calls, struct and rosbags' CDR: never pitchside's wire.actions, wire.ros2.actions or its runtime's action server,
so pitchside's side can only meet these if it speaks the documented protocol.

    <domain>/<action>/_action/send_goal/<pkg>::action::dds_::PlayAnimation_SendGoal_/<hash>     queryable
    <domain>/<action>/_action/cancel_goal/action_msgs::srv::dds_::CancelGoal_/<hash>            queryable
    <domain>/<action>/_action/get_result/<pkg>::action::dds_::PlayAnimation_GetResult_/<hash>   queryable
    <domain>/<action>/_action/feedback/<pkg>::action::dds_::PlayAnimation_FeedbackMessage_/<hash>
    <domain>/<action>/_action/status/action_msgs::msg::dds_::GoalStatusArray_/<hash>

The hashes of action_msgs' types are the ones ROS 2 Jazzy publishes (``ros2 action info -v`` prints them); those
of humanoid_league_msgs' PlayAnimation come from schemas.type_hash (tested against ROS 2's own in
test_type_hash.py).
"""

from __future__ import annotations

import struct
import threading
import time
from typing import Any

import numpy as np
import zenoh
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from schemas import codec

CANCEL_GOAL_HASH = "RIHS01_573d8b0a534451d7bc2ac8c5ffde8ac14b8593b7001175d0cd6516dcbeb8689a"
GOAL_STATUS_ARRAY_HASH = "RIHS01_6c1684b00f177d37438febe6e709fc4e2b0d4248dca4854946f9ed8b30cda83e"
ACTION_TYPE = "humanoid_league_msgs/action/PlayAnimation"
SUCCEEDED, CANCELED, ABORTED, EXECUTING, CANCELING, UNKNOWN = 4, 5, 6, 2, 3, 0

# PlayAnimation.action and the types ROS 2 derives from it, as the peer's own (names do not travel in CDR)
_DEFINITIONS = {
    "peer_msgs/msg/Goal": "string animation\nbool hcm\n",
    "peer_msgs/msg/Result": "bool successful\nstring message\n",
    "peer_msgs/msg/Feedback": "float32 percent_done\n",
    "peer_msgs/msg/SendGoalRequest": "unique_identifier_msgs/UUID goal_id\npeer_msgs/Goal goal\n",
    "peer_msgs/msg/SendGoalResponse": "bool accepted\nbuiltin_interfaces/Time stamp\n",
    "peer_msgs/msg/GetResultRequest": "unique_identifier_msgs/UUID goal_id\n",
    "peer_msgs/msg/GetResultResponse": "int8 status\npeer_msgs/Result result\n",
    "peer_msgs/msg/FeedbackMessage": "unique_identifier_msgs/UUID goal_id\npeer_msgs/Feedback feedback\n",
    "peer_msgs/msg/CancelRequest": "action_msgs/GoalInfo goal_info\n",
    "peer_msgs/msg/CancelResponse": "int8 return_code\naction_msgs/GoalInfo[] goals_canceling\n",
}
STORE = get_typestore(Stores.ROS2_JAZZY)
for _name, _text in _DEFINITIONS.items():
    STORE.register(get_types_from_msg(_text, _name))


def make(name: str, **fields: Any) -> Any:
    return STORE.types[name](**fields)


def encode(name: str, **fields: Any) -> bytes:
    return bytes(STORE.serialize_cdr(make(name, **fields), name))


def decode(name: str, data: bytes) -> Any:
    return STORE.deserialize_cdr(data, name)


def uuid(goal_id: bytes) -> Any:
    return make("unique_identifier_msgs/msg/UUID", uuid=np.frombuffer(goal_id, dtype=np.uint8).copy())


def time_msg(ns: int) -> Any:
    return make("builtin_interfaces/msg/Time", sec=ns // 10**9, nanosec=ns % 10**9)


def attachment(sequence_number: int, gid: bytes) -> bytes:
    """rmw_zenoh's: int64 sequence number, int64 source timestamp (ns), GID length (1 byte, 16), GID."""
    return struct.pack("<qqB", sequence_number, time.time_ns(), len(gid)) + gid


def read_attachment(data: bytes) -> tuple[int, bytes]:
    sequence_number, _, length = struct.unpack_from("<qqB", data)
    assert length == 16 and len(data) == 33, data
    return sequence_number, data[17:]


def keys(domain: int, action: str) -> dict[str, str]:
    """The data keys of the five parts of ``action`` (``/robot1/animation``)."""
    base = f"{domain}/{action.strip('/')}/_action"
    pkg = "humanoid_league_msgs::action::dds_::PlayAnimation"
    return {
        "send_goal": f"{base}/send_goal/{pkg}_SendGoal_/{codec.type_hash(ACTION_TYPE + '_SendGoal')}",
        "cancel_goal": f"{base}/cancel_goal/action_msgs::srv::dds_::CancelGoal_/{CANCEL_GOAL_HASH}",
        "get_result": f"{base}/get_result/{pkg}_GetResult_/{codec.type_hash(ACTION_TYPE + '_GetResult')}",
        "feedback": f"{base}/feedback/{pkg}_FeedbackMessage_/{codec.type_hash(ACTION_TYPE + '_FeedbackMessage')}",
        "status": f"{base}/status/action_msgs::msg::dds_::GoalStatusArray_/{GOAL_STATUS_ARRAY_HASH}",
    }


class PeerActionClient:
    """What rclpy's ActionClient does on the wire: services called with the attachment, topics followed."""

    def __init__(self, session: zenoh.Session, domain: int, action: str) -> None:
        self.session = session
        self.keys = keys(domain, action)
        self.gid = bytes(range(200, 216))
        self.sequence_number = 0
        self.feedback: list[tuple[bytes, float]] = []
        self.statuses: list[dict[bytes, int]] = []
        self.samples_without_attachment = 0
        self._subscribers = [session.declare_subscriber(self.keys["feedback"], self._on_feedback),
                             session.declare_subscriber(self.keys["status"], self._on_status)]

    def _checked(self, sample: zenoh.Sample) -> bool:
        if sample.attachment is None:
            self.samples_without_attachment += 1
            return False
        read_attachment(sample.attachment.to_bytes())
        return True

    def _on_feedback(self, sample: zenoh.Sample) -> None:
        if self._checked(sample):
            message = decode("peer_msgs/msg/FeedbackMessage", sample.payload.to_bytes())
            self.feedback.append((bytes(message.goal_id.uuid), float(message.feedback.percent_done)))

    def _on_status(self, sample: zenoh.Sample) -> None:
        if self._checked(sample):
            array = decode("action_msgs/msg/GoalStatusArray", sample.payload.to_bytes())
            self.statuses.append({bytes(s.goal_info.goal_id.uuid): int(s.status) for s in array.status_list})

    def call(self, part: str, payload: bytes, timeout_s: float = 10.0, with_attachment: bool = True) -> bytes | None:
        """The reply's CDR, checking its attachment names this request; None if nobody answered."""
        self.sequence_number += 1
        sent = self.sequence_number
        replies = self.session.get(self.keys[part], target=zenoh.QueryTarget.ALL_COMPLETE, payload=payload,
                                   attachment=attachment(sent, self.gid) if with_attachment else None,
                                   timeout=timeout_s)
        for reply in replies:
            assert reply.ok is not None, reply.err.payload.to_string() if reply.err is not None else reply
            assert reply.ok.attachment is not None, "a reply without rmw_zenoh's attachment"
            assert read_attachment(reply.ok.attachment.to_bytes()) == (sent, self.gid)
            return reply.ok.payload.to_bytes()
        return None

    def send_goal(self, goal_id: bytes, animation: str, hcm: bool = False) -> tuple[bool, int]:
        """(accepted, stamp in ns)."""
        request = encode("peer_msgs/msg/SendGoalRequest", goal_id=uuid(goal_id),
                         goal=make("peer_msgs/msg/Goal", animation=animation, hcm=hcm))
        cdr = self.call("send_goal", request)
        assert cdr is not None, "no answer to send_goal"
        response = decode("peer_msgs/msg/SendGoalResponse", cdr)
        return bool(response.accepted), response.stamp.sec * 10**9 + response.stamp.nanosec

    def get_result(self, goal_id: bytes, timeout_s: float = 30.0) -> tuple[int, Any]:
        cdr = self.call("get_result", encode("peer_msgs/msg/GetResultRequest", goal_id=uuid(goal_id)), timeout_s)
        assert cdr is not None, "no answer to get_result"
        response = decode("peer_msgs/msg/GetResultResponse", cdr)
        return int(response.status), response.result

    def cancel(self, goal_id: bytes, stamp_ns: int = 0) -> tuple[int, list[bytes]]:
        """(return code, ids of the goals now canceling)."""
        info = make("action_msgs/msg/GoalInfo", goal_id=uuid(goal_id), stamp=time_msg(stamp_ns))
        cdr = self.call("cancel_goal", encode("peer_msgs/msg/CancelRequest", goal_info=info))
        assert cdr is not None, "no answer to cancel_goal"
        response = decode("peer_msgs/msg/CancelResponse", cdr)
        return int(response.return_code), [bytes(g.goal_id.uuid) for g in response.goals_canceling]

    def close(self) -> None:
        for subscriber in self._subscribers:
            subscriber.undeclare()


class PeerActionServer:
    """A ROS 2 robot's PlayAnimation server: accepts every goal but "refuse", plays only when the test says
    (``feedback``, ``finish``); answers get_result when the goal ends, cancels on request."""

    def __init__(self, session: zenoh.Session, domain: int, namespace: str, node: str, action: str) -> None:
        self.session = session
        self.keys = keys(domain, action)
        self.gid = bytes(range(50, 66))
        self.goals: dict[bytes, dict[str, Any]] = {}  # id -> animation, status, stamp, result, waiting queries
        self.cancel_requests = 0
        self._lock = threading.Lock()
        self._sequence_number = 0
        zid = str(session.zid())
        self._queryables = [session.declare_queryable(self.keys[part], handler, complete=True) for part, handler in
                            (("send_goal", self._on_send_goal), ("cancel_goal", self._on_cancel),
                             ("get_result", self._on_get_result))]
        ns, name = namespace.replace("/", "%"), f"{namespace.rstrip('/')}/{action.strip('/').split('/')[-1]}"
        lv = session.liveliness()
        tokens = [f"@ros2_lv/{domain}/{zid}/0/0/NN/%/{ns}/{node}"]
        for entity_id, (kind, part) in enumerate((("SS", "send_goal"), ("SS", "cancel_goal"), ("SS", "get_result"),
                                                  ("MP", "feedback"), ("MP", "status")), start=1):
            _, _, dds, type_hash = self.keys[part].rsplit("/", 3)
            qos = ":1:,1:,:,:,," if part == "status" else "::,10:,:,:,,"
            tokens.append(f"@ros2_lv/{domain}/{zid}/0/{entity_id}/{kind}/%/{ns}/{node}/"
                          f"{(name + '/_action/' + part).replace('/', '%')}/{dds}/{type_hash}/{qos}")
        self._tokens = [lv.declare_token(token) for token in tokens]

    def _reply(self, query: zenoh.Query, key: str, payload: bytes) -> None:
        assert query.attachment is not None
        sequence_number, gid = read_attachment(query.attachment.to_bytes())
        query.reply(key, payload, attachment=attachment(sequence_number, gid))
        query.drop()

    def _on_send_goal(self, query: zenoh.Query) -> None:
        request = decode("peer_msgs/msg/SendGoalRequest", query.payload.to_bytes())
        goal_id, accepted, stamp = bytes(request.goal_id.uuid), request.goal.animation != "refuse", time.time_ns()
        if accepted:
            with self._lock:
                self.goals[goal_id] = {"animation": request.goal.animation, "status": EXECUTING, "stamp": stamp,
                                       "result": None, "waiting": []}
            self._publish_status()
        self._reply(query, self.keys["send_goal"], encode("peer_msgs/msg/SendGoalResponse", accepted=accepted,
                                                          stamp=time_msg(stamp if accepted else 0)))

    def _on_get_result(self, query: zenoh.Query) -> None:
        goal_id = bytes(decode("peer_msgs/msg/GetResultRequest", query.payload.to_bytes()).goal_id.uuid)
        with self._lock:
            goal = self.goals.get(goal_id)
            if goal is not None and goal["result"] is None:
                goal["waiting"].append(query)
                return
        status, result = (goal["status"], goal["result"]) if goal else (UNKNOWN, make("peer_msgs/msg/Result",
                                                                                        successful=False, message=""))
        self._reply(query, self.keys["get_result"], encode("peer_msgs/msg/GetResultResponse", status=status,
                                                           result=result))

    def _on_cancel(self, query: zenoh.Query) -> None:
        info = decode("peer_msgs/msg/CancelRequest", query.payload.to_bytes()).goal_info
        goal_id = bytes(info.goal_id.uuid)
        self.cancel_requests += 1
        goal = self.goals.get(goal_id)
        canceling = goal is not None and goal["result"] is None
        self._reply(query, self.keys["cancel_goal"], encode(
            "peer_msgs/msg/CancelResponse", return_code=0 if canceling else 2 if goal is None else 3,
            goals_canceling=[info] if canceling else []))
        if canceling:
            self.finish(goal_id, CANCELED, successful=False, message="canceled")

    def feedback(self, goal_id: bytes, percent: float) -> None:
        payload = encode("peer_msgs/msg/FeedbackMessage", goal_id=uuid(goal_id),
                         feedback=make("peer_msgs/msg/Feedback", percent_done=percent))
        self.session.put(self.keys["feedback"], payload, attachment=self._next_attachment())

    def finish(self, goal_id: bytes, status: int, successful: bool, message: str) -> None:
        with self._lock:
            goal = self.goals[goal_id]
            goal["status"], goal["result"] = status, make("peer_msgs/msg/Result", successful=successful,
                                                          message=message)
            waiting, goal["waiting"] = goal["waiting"], []
        self._publish_status()
        for query in waiting:
            self._reply(query, self.keys["get_result"], encode("peer_msgs/msg/GetResultResponse", status=status,
                                                               result=goal["result"]))

    def _publish_status(self) -> None:
        with self._lock:
            statuses = [make("action_msgs/msg/GoalStatus", status=goal["status"], goal_info=make(
                "action_msgs/msg/GoalInfo", goal_id=uuid(goal_id), stamp=time_msg(goal["stamp"])))
                for goal_id, goal in self.goals.items()]
        payload = bytes(STORE.serialize_cdr(make("action_msgs/msg/GoalStatusArray", status_list=statuses),
                                            "action_msgs/msg/GoalStatusArray"))
        self.session.put(self.keys["status"], payload, attachment=self._next_attachment())

    def _next_attachment(self) -> bytes:
        with self._lock:
            self._sequence_number += 1
            return attachment(self._sequence_number, self.gid)

    def close(self) -> None:
        for queryable in self._queryables:
            queryable.undeclare()
        for token in self._tokens:
            token.undeclare()
