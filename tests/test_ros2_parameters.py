"""Node parameters as ROS 2 defines them, on real Zenoh sessions through a router on loopback.

The ROS 2 side is written here from the protocol descriptions (rcl_interfaces' .srv files, rmw_zenoh 0.2.x's
design notes for keys, tokens and the attachment) with raw Zenoh calls, struct and rosbags' CDR, never pitchside's
wire.ros2: a ROS 2 client that lists, gets and sets a pitchside node's parameters and hears /parameter_events, and
a ROS 2 node whose parameters the dashboard lists and sets.
"""

from __future__ import annotations

import struct
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import zenoh
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from robot_nodes.runtime import BusConfig, Node, ParameterClient, open_session, param
from schemas import codec
from tests.dashboard_server import dashboard_server
from tests.waiting import wait_for

# published by ROS 2 (rosidl's generated code of rcl_interfaces, as other rmw_zenoh clients quote it)
PUBLISHED_HASHES = {
    "rcl_interfaces/srv/ListParameters": "RIHS01_3e6062bfbb27bfb8730d4cef2558221f51a11646d78e7bb30a1e83afac3aad9d",
    "rcl_interfaces/srv/GetParameters": "RIHS01_bf9803d5c74cf989a5de3e0c2e99444599a627c7ff75f97b8c05b01003675cbc",
    "rcl_interfaces/srv/SetParameters": "RIHS01_56eed9a67e169f9cb6c1f987bc88f868c14a8fc9f743a263bc734c154015d7e0",
    "rcl_interfaces/srv/GetParameterTypes": "RIHS01_da199c878688b3e530bdfe3ca8f74cb9fa0c303101e980a9e8f260e25e1c80ca",
    "rcl_interfaces/msg/ParameterEvent": "RIHS01_043e627780fcad87a22d225bc2a037361dba713fca6a6b9f4b869a5aa0393204",
}
PUBLISHED_PREFIXES = {  # only the start of these was quoted
    "rcl_interfaces/srv/DescribeParameters": "RIHS01_845b484d7",
    "rcl_interfaces/srv/SetParametersAtomically": "RIHS01_0e192ef259c07fc3c07a13191d27002222e65e00ccec653ca05e856f7928",
}
# the services' halves as rcl_interfaces (Jazzy) defines them
SERVICES = {
    "ListParameters": ("string[] prefixes\nuint64 depth\n", "rcl_interfaces/msg/ListParametersResult result\n"),
    "DescribeParameters": ("string[] names\n", "rcl_interfaces/msg/ParameterDescriptor[] descriptors\n"),
    "GetParameters": ("string[] names\n", "rcl_interfaces/msg/ParameterValue[] values\n"),
    "SetParameters": ("rcl_interfaces/msg/Parameter[] parameters\n",
                      "rcl_interfaces/msg/SetParametersResult[] results\n"),
    "SetParametersAtomically": ("rcl_interfaces/msg/Parameter[] parameters\n",
                                "rcl_interfaces/msg/SetParametersResult result\n"),
    "GetParameterTypes": ("string[] names\n", "uint8[] types\n"),
}
SERVICE_NAMES = {"ListParameters": "list_parameters", "DescribeParameters": "describe_parameters",
                 "GetParameters": "get_parameters", "SetParameters": "set_parameters",
                 "SetParametersAtomically": "set_parameters_atomically", "GetParameterTypes": "get_parameter_types"}
DOUBLE, INTEGER, STRING = 3, 2, 4  # rcl_interfaces/msg/ParameterType
EVENTS_KEY = ("0/parameter_events/rcl_interfaces::msg::dds_::ParameterEvent_/"
              + PUBLISHED_HASHES["rcl_interfaces/msg/ParameterEvent"])


def ros2_store() -> Typestore:
    store = get_typestore(Stores.ROS2_JAZZY)
    for name, halves in SERVICES.items():
        for half, text in zip(("Request", "Response"), halves, strict=True):
            (definition,) = get_types_from_msg(text, f"rcl_interfaces/srv/{name}_{half}").values()
            store.register({f"rcl_interfaces/srv/{name}_{half}": definition})  # rosbags files it under srv/msg/
    return store


ROS2 = ros2_store()


def service_hash(name: str) -> str:
    return PUBLISHED_HASHES.get(f"rcl_interfaces/srv/{name}") or codec.type_hash(f"rcl_interfaces/srv/{name}")


def service_key(domain: int, node_fqn: str, name: str) -> str:
    """design.md: <domain>/<name without leading '/'>/<pkg>::srv::dds_::<Type>_/<hash>."""
    return (f"{domain}/{node_fqn.strip('/')}/{SERVICE_NAMES[name]}/rcl_interfaces::srv::dds_::{name}_/"
            f"{service_hash(name)}")


def attachment(sequence_number: int, gid: bytes) -> bytes:
    """design.md: int64 sequence number, int64 source timestamp (ns), the GID's length (16) and its 16 bytes."""
    return struct.pack("<qqB", sequence_number, time.time_ns(), len(gid)) + gid


def read_attachment(data: bytes) -> tuple[int, bytes]:
    assert len(data) == 33
    sequence_number, _, length = struct.unpack_from("<qqB", data)
    assert length == 16
    return sequence_number, data[17:]


def value(kind: int, python: Any) -> Any:
    fields: dict[str, Any] = {"type": kind, "bool_value": False, "integer_value": 0, "double_value": 0.0,
                              "string_value": "", "byte_array_value": np.zeros(0, np.uint8),
                              "bool_array_value": np.zeros(0, np.bool_), "integer_array_value": np.zeros(0, np.int64),
                              "double_array_value": np.zeros(0, np.float64), "string_array_value": []}
    fields[{DOUBLE: "double_value", INTEGER: "integer_value", STRING: "string_value"}[kind]] = python
    return ROS2.types["rcl_interfaces/msg/ParameterValue"](**fields)


def python_value(message: Any) -> Any:
    return {DOUBLE: message.double_value, INTEGER: message.integer_value, STRING: message.string_value}.get(
        int(message.type))


def parameters(**values: tuple[int, Any]) -> list[Any]:
    return [ROS2.types["rcl_interfaces/msg/Parameter"](name=n, value=value(*v)) for n, v in values.items()]


class Ros2Caller:
    """A ROS 2 client as rmw_zenoh calls: a get to the service's key, with the attachment, one reply checked."""

    def __init__(self, session: zenoh.Session, domain: int = 0) -> None:
        self.session = session
        self.domain = domain
        self.gid = bytes(range(200, 216))
        self.sequence_number = 0

    def call(self, node_fqn: str, name: str, **request: Any) -> Any:
        self.sequence_number += 1
        sent = self.sequence_number
        payload = bytes(ROS2.serialize_cdr(ROS2.types[f"rcl_interfaces/srv/{name}_Request"](**request),
                                           f"rcl_interfaces/srv/{name}_Request"))
        replies = list(self.session.get(service_key(self.domain, node_fqn, name), payload=payload,
                                        attachment=attachment(sent, self.gid), timeout=5.0))
        assert len(replies) == 1 and replies[0].ok is not None, replies
        sample = replies[0].ok
        assert sample.attachment is not None
        assert read_attachment(sample.attachment.to_bytes()) == (sent, self.gid)  # the reply is to this request
        return ROS2.deserialize_cdr(sample.payload.to_bytes(), f"rcl_interfaces/srv/{name}_Response")


@dataclass
class WalkParams:
    step_length_m: float = param(0.05, range=(0.0, 0.1), doc="how far one step goes")
    steps_per_cycle: int = param(2, range=(1, 4), doc="steps in one cycle")
    gait: str = param("omni", choices=["omni", "forward"], doc="which gait")
    servo_port: str = param("/dev/ttyUSB0", startup=True, doc="read once at start-up")


class Walking(Node):
    name = "walking"
    Params = WalkParams


@pytest.fixture
def peer(bus: BusConfig) -> Iterator[zenoh.Session]:
    session = open_session(bus)
    yield session
    session.close()


def test_pitchside_computes_the_hashes_ros2_published_for_the_parameter_services() -> None:
    for name, published in PUBLISHED_HASHES.items():
        assert codec.type_hash(name) == published, name
    for name, prefix in PUBLISHED_PREFIXES.items():
        assert codec.type_hash(name).startswith(prefix), name


def test_a_ros2_client_lists_gets_and_sets_a_pitchside_nodes_parameters(bus: BusConfig, peer: zenoh.Session) -> None:
    """What ``ros2 param list/describe/get/set /robot1/walking`` sends, and /parameter_events as it hears them."""
    tokens: set[str] = set()
    lv = peer.liveliness().declare_subscriber("@ros2_lv/0/**", lambda s: tokens.add(str(s.key_expr)), history=True)
    events: list[tuple[Any, tuple[int, bytes]]] = []
    event_key = EVENTS_KEY
    events_sub = peer.declare_subscriber(event_key, lambda s: events.append((
        ROS2.deserialize_cdr(s.payload.to_bytes(), "rcl_interfaces/msg/ParameterEvent"),
        read_attachment(s.attachment.to_bytes() if s.attachment is not None else b""))))
    node = Walking("robot1", bus).start()
    try:
        zid = str(node.session.zid())
        list_token = (f"@ros2_lv/0/{zid}/{node.ros2_node_id}/*/SS/%/%robot1/walking/%robot1%walking%list_parameters/"
                      f"rcl_interfaces::srv::dds_::ListParameters_/{service_hash('ListParameters')}/::,1000:,:,:,,")
        wait_for(lambda: any(zenoh.KeyExpr(list_token).intersects(zenoh.KeyExpr(t)) for t in tokens),
                 what=lambda: f"the node's list_parameters token (rmw_qos_profile_parameters), saw {sorted(tokens)}")
        ros2 = Ros2Caller(peer)
        listed = wait_for(lambda: _answered(lambda: ros2.call("/robot1/walking", "ListParameters", prefixes=[],
                                                              depth=0)), what="list_parameters answered")
        assert sorted(listed.result.names) == ["gait", "servo_port", "step_length_m", "steps_per_cycle"]

        described = {d.name: d for d in ros2.call("/robot1/walking", "DescribeParameters",
                                                  names=["step_length_m", "steps_per_cycle", "servo_port", "gait"]
                                                  ).descriptors}
        step = described["step_length_m"]
        assert step.type == DOUBLE and step.description == "how far one step goes" and not step.read_only
        assert [(r.from_value, r.to_value) for r in step.floating_point_range] == [(0.0, 0.1)]
        assert [(r.from_value, r.to_value) for r in described["steps_per_cycle"].integer_range] == [(1, 4)]
        assert described["servo_port"].read_only and described["servo_port"].type == STRING
        assert "omni" in described["gait"].additional_constraints

        got = ros2.call("/robot1/walking", "GetParameters", names=["step_length_m", "gait", "nope"]).values
        assert [int(v.type) for v in got] == [DOUBLE, STRING, 0] and got[0].double_value == 0.05
        assert list(ros2.call("/robot1/walking", "GetParameterTypes", names=["steps_per_cycle"]).types) == [INTEGER]

        events.clear()
        (result,) = ros2.call("/robot1/walking", "SetParameters",
                              parameters=parameters(step_length_m=(DOUBLE, 0.08))).results
        assert result.successful, result.reason
        assert node.params.step_length_m == 0.08
        event, (sequence_number, gid) = wait_for(lambda: events and events[-1], what="the /parameter_events sample")
        assert event.node == "/robot1/walking" and sequence_number >= 1 and len(gid) == 16
        assert [(p.name, python_value(p.value)) for p in event.changed_parameters] == [("step_length_m", 0.08)]

        (refused,) = ros2.call("/robot1/walking", "SetParameters",
                               parameters=parameters(step_length_m=(DOUBLE, 0.5))).results
        assert not refused.successful and "out of range [0.0, 0.1]" in refused.reason
        atomic = ros2.call("/robot1/walking", "SetParametersAtomically",
                           parameters=parameters(gait=(STRING, "forward"), steps_per_cycle=(INTEGER, 9))).result
        assert not atomic.successful and "steps_per_cycle" in atomic.reason
        (startup,) = ros2.call("/robot1/walking", "SetParameters",
                               parameters=parameters(servo_port=(STRING, "/dev/ttyS1"))).results
        assert not startup.successful and "read once when walking starts" in startup.reason
        assert (node.params.step_length_m, node.params.gait, node.params.steps_per_cycle) == (0.08, "omni", 2)
    finally:
        node.shutdown()
        events_sub.undeclare()
        lv.undeclare()


def _answered(call: Callable[[], Any]) -> Any:
    """The call's answer, or None while the node's queryable is not yet routed to the caller."""
    try:
        return call()
    except AssertionError:
        return None


def test_bad_requests_are_counted_and_the_node_goes_on(bus: BusConfig, peer: zenoh.Session) -> None:
    node = Walking("robot1", bus).start()
    try:
        ros2 = Ros2Caller(peer)
        wait_for(lambda: _answered(lambda: ros2.call("/robot1/walking", "ListParameters", prefixes=[], depth=0)),
                 what="list_parameters answered")
        key = service_key(0, "/robot1/walking", "SetParameters")
        good = bytes(ROS2.serialize_cdr(ROS2.types["rcl_interfaces/srv/SetParameters_Request"](
            parameters=parameters(step_length_m=(DOUBLE, 0.02))), "rcl_interfaces/srv/SetParameters_Request"))
        unattached = list(peer.get(key, payload=good, timeout=1.0))
        assert all(r.ok is None for r in unattached)  # no attachment: dropped, no answer
        wait_for(lambda: node._parameter_server.bad_requests == 1, what="the request without attachment counted")
        assert node.params.step_length_m == 0.05  # not applied
        replies = list(peer.get(key, payload=b"\x00\x01\x00\x00\xff\xff\xff\x7f", attachment=attachment(1, bytes(16)),
                                timeout=5.0))
        assert len(replies) == 1 and replies[0].err is not None  # a request that does not decode: an error reply
        short = list(peer.get(key, payload=good, attachment=b"\x01\x02", timeout=1.0))
        assert all(r.ok is None for r in short)  # a short attachment: dropped like a missing one
        wait_for(lambda: node._parameter_server.bad_requests == 3, what="all three bad requests counted")
        (result,) = ros2.call("/robot1/walking", "SetParameters", parameters=parameters(step_length_m=(DOUBLE, 0.02))
                              ).results
        assert result.successful and node.params.step_length_m == 0.02  # still answering
    finally:
        node.shutdown()


class Ros2ParameterNode:
    """A ROS 2 node with parameters as rclcpp's ParameterService offers them (the six services; no pitchside
    additions): its tokens, complete queryables that answer with the attachment, values kept here."""

    def __init__(self, session: zenoh.Session, namespace: str, name: str,
                 values: dict[str, tuple[int, Any]] | None = None, doc: str = "the camera's") -> None:
        self.fqn = f"{namespace}/{name}"
        self.values = values or {"exposure_ms": (DOUBLE, 10.0), "camera_mode": (STRING, "auto")}
        self.ranges = {"exposure_ms": (1.0, 100.0)}
        self.doc = doc
        zid = str(session.zid())
        lv = session.liveliness()
        mangled_ns = namespace.replace("/", "%")
        self._declared: list[Any] = [lv.declare_token(f"@ros2_lv/0/{zid}/0/0/NN/%/{mangled_ns}/{name}")]
        handlers = {"ListParameters": self._list, "DescribeParameters": self._describe,
                    "GetParameters": self._get, "SetParameters": self._set, "SetParametersAtomically": self._atomic,
                    "GetParameterTypes": self._types}
        for entity_id, (srv, handler) in enumerate(handlers.items(), start=1):
            key = service_key(0, self.fqn, srv)
            service_name = f"{self.fqn}/{SERVICE_NAMES[srv]}".replace("/", "%")
            self._declared.append(lv.declare_token(
                f"@ros2_lv/0/{zid}/0/{entity_id}/SS/%/{mangled_ns}/{name}/{service_name}/"
                f"rcl_interfaces::srv::dds_::{srv}_/{service_hash(srv)}/::,1000:,:,:,,"))
            self._declared.append(session.declare_queryable(key, self._answer(key, srv, handler), complete=True))

    def _answer(self, key: str, srv: str, handler: Callable[[Any], Any]) -> Callable[[zenoh.Query], None]:
        def answer(query: zenoh.Query) -> None:
            if query.attachment is None or query.payload is None:
                return
            sequence_number, gid = read_attachment(query.attachment.to_bytes())
            request = ROS2.deserialize_cdr(query.payload.to_bytes(), f"rcl_interfaces/srv/{srv}_Request")
            response = bytes(ROS2.serialize_cdr(handler(request), f"rcl_interfaces/srv/{srv}_Response"))
            query.reply(key, response, attachment=attachment(sequence_number, gid))
        return answer

    def _response(self, srv: str, **fields: Any) -> Any:
        return ROS2.types[f"rcl_interfaces/srv/{srv}_Response"](**fields)

    def _list(self, _request: Any) -> Any:
        result = ROS2.types["rcl_interfaces/msg/ListParametersResult"](names=sorted(self.values), prefixes=[])
        return self._response("ListParameters", result=result)

    def _describe(self, request: Any) -> Any:
        descriptors = []
        for name in request.names:
            low_high = self.ranges.get(name)
            ranges = [ROS2.types["rcl_interfaces/msg/FloatingPointRange"](
                from_value=low_high[0], to_value=low_high[1], step=0.0)] if low_high else []
            descriptors.append(ROS2.types["rcl_interfaces/msg/ParameterDescriptor"](
                name=name, type=self.values[name][0], description=f"{self.doc} {name}", additional_constraints="",
                read_only=False, dynamic_typing=False, floating_point_range=ranges, integer_range=[]))
        return self._response("DescribeParameters", descriptors=descriptors)

    def _get(self, request: Any) -> Any:
        return self._response("GetParameters", values=[value(*self.values[n]) for n in request.names])

    def _types(self, request: Any) -> Any:
        return self._response("GetParameterTypes", types=np.array([self.values[n][0] for n in request.names],
                                                                  dtype=np.uint8))

    def _check(self, parameter: Any) -> str:
        low_high = self.ranges.get(parameter.name)
        given = python_value(parameter.value)
        if parameter.name not in self.values:
            return f"no parameter {parameter.name}"
        if low_high and not low_high[0] <= given <= low_high[1]:
            return f"{parameter.name} must be within [{low_high[0]}, {low_high[1]}]"
        return ""

    def _result(self, reason: str) -> Any:
        return ROS2.types["rcl_interfaces/msg/SetParametersResult"](successful=not reason, reason=reason)

    def _set(self, request: Any) -> Any:
        results = []
        for p in request.parameters:
            reason = self._check(p)
            if not reason:
                self.values[p.name] = (int(p.value.type), python_value(p.value))
            results.append(self._result(reason))
        return self._response("SetParameters", results=results)

    def _atomic(self, request: Any) -> Any:
        reasons = [r for r in (self._check(p) for p in request.parameters) if r]
        if not reasons:
            for p in request.parameters:
                self.values[p.name] = (int(p.value.type), python_value(p.value))
        return self._response("SetParametersAtomically", result=self._result("; ".join(reasons)))

    def close(self) -> None:
        for declared in self._declared:
            declared.undeclare()


def test_the_dashboard_lists_and_sets_a_ros2_nodes_parameters(router_endpoint: str, peer: zenoh.Session,
                                                              tmp_path: Path) -> None:
    camera = Ros2ParameterNode(peer, "/robot7", "camera")
    try:
        client = ParameterClient(peer, "robot7", timeout=10.0)  # the client the server uses, here in the test
        assert client.describe("camera")[0]["name"] == "camera_mode"
        with dashboard_server(["--connect", router_endpoint, "--no-telemetry"], tmp_path) as server:
            url = f"{server.url}/api/robots/robot7/params"
            listed = wait_for(lambda: (r := server.http.get(url, timeout=20)).status_code == 200 and
                              r.json().get("camera") and r.json(), 40.0, 0.2, "the ROS 2 node's parameters listed")
            exposure = {p["name"]: p for p in listed["camera"]}["exposure_ms"]
            assert exposure["value"] == 10.0 and exposure["range"] == [1.0, 100.0] and exposure["type"] == "float"
            assert exposure["doc"] == "the camera's exposure_ms" and exposure["revision"] == 0
            reply = server.http.post(f"{url}/camera", json={"values": {"exposure_ms": 20.0}}, timeout=20)
            assert reply.status_code == 200, reply.text
            assert camera.values["exposure_ms"] == (DOUBLE, 20.0)
            assert {p["name"]: p["value"] for p in reply.json()["params"]}["exposure_ms"] == 20.0
            refused = server.http.post(f"{url}/camera", json={"values": {"exposure_ms": 500.0}}, timeout=20)
            assert refused.status_code == 422 and "within [1.0, 100.0]" in refused.text
            assert camera.values["exposure_ms"] == (DOUBLE, 20.0)
            no_defaults = server.http.post(f"{url}/camera/reset", json={"names": []}, timeout=20)
            assert no_defaults.status_code == 422 and "defaults" in no_defaults.text
            # the panel's own reset writes the defaults it was told: none, so nothing is sent (NOT_SET would delete)
            unset = server.http.post(f"{url}/camera", json={"values": {"exposure_ms": None}}, timeout=20)
            assert unset.status_code == 422 and camera.values["exposure_ms"] == (DOUBLE, 20.0)
            diff = server.http.get(f"{url}/camera/diff", timeout=20)
            assert diff.status_code == 200 and diff.json()["changes"] == []  # no defaults, no file: nothing differs
    finally:
        camera.close()


def test_the_dashboards_events_carry_a_pitchside_nodes_change_with_its_revision(
        bus: BusConfig, peer: zenoh.Session) -> None:
    """The caller's side of /parameter_events: a change made with ``ros2 param set`` reaches the follower."""
    node = Walking("robot1", bus).start()
    seen: list[tuple[str, dict[str, Any]]] = []
    client = ParameterClient(peer, "robot1", timeout=5.0)
    events = client.follow("*", lambda name, changed: seen.append((name, changed)))
    try:
        ros2 = Ros2Caller(peer)
        wait_for(lambda: _answered(lambda: ros2.call("/robot1/walking", "ListParameters", prefixes=[], depth=0)),
                 what="list_parameters answered")

        def changed_once() -> bool:  # set again until the follower's subscription is routed
            gait = "forward" if len(seen) % 2 == 0 else "omni"
            ros2.call("/robot1/walking", "SetParameters", parameters=parameters(gait=(STRING, gait)))
            return bool(seen)
        wait_for(changed_once, what="a change heard on /parameter_events")
        assert seen[0][0] == "walking" and "gait" in seen[0][1]
        states = client.states("walking", ["gait"])
        assert states["gait"]["value"] == node.params.gait and states["gait"]["revision"] >= 1
        peer.put(EVENTS_KEY, b"\x00\x01\x00\x00\xff",
                 attachment=attachment(1, bytes(16)))
        wait_for(lambda: events.bad_events == 1, what="the event that does not decode counted")
    finally:
        events.close()
        node.shutdown()


def test_a_ros2_name_for_the_robot_is_required(peer: zenoh.Session) -> None:
    with pytest.raises(ValueError, match="no ROS 2 namespace"):
        ParameterClient(peer, "9lives")



class Referee(Node):
    """Serves the table's manual_penalize, as the HCM does."""

    name = "referee"

    def setup(self) -> None:
        self.service("manual_penalize", lambda request: codec.make(
            "humanoid_league_msgs/srv/ManualPenalize_Response", penalized=request.penalize == 1))


def test_a_service_of_the_table_is_a_ros2_service_both_ways(bus: BusConfig, peer: zenoh.Session) -> None:
    """/robot1/manual_penalize as rmw_zenoh serves it (SS token, a complete queryable, the reply's attachment), and
    call_service as rmw_zenoh's clients call (an SC token of the caller node, the attachment)."""
    from wire.services import call_service

    srv_hash = codec.type_hash("humanoid_league_msgs/srv/ManualPenalize")
    dds = "humanoid_league_msgs::srv::dds_::ManualPenalize_"
    tokens: set[str] = set()
    lv = peer.liveliness().declare_subscriber("@ros2_lv/0/**", lambda s: tokens.add(str(s.key_expr)), history=True)
    node = Referee("robot1", bus).start()
    try:
        server_token = (f"@ros2_lv/0/{node.zid}/{node.ros2_node_id}/*/SS/%/%robot1/referee/%robot1%manual_penalize/"
                        f"{dds}/{srv_hash}/::,10:,:,:,,")
        wait_for(lambda: any(zenoh.KeyExpr(server_token).intersects(zenoh.KeyExpr(t)) for t in tokens),
                 what=lambda: f"the service's SS token, saw {sorted(tokens)}")
        request = codec.encode(codec.make("humanoid_league_msgs/srv/ManualPenalize_Request", penalize=1))
        gid = bytes(range(50, 66))
        replies = wait_for(lambda: [r for r in peer.get(f"0/robot1/manual_penalize/{dds}/{srv_hash}", payload=request,
                                                        attachment=attachment(7, gid), timeout=2.0) if r.ok],
                           what="the service's reply")
        reply = replies[0].ok
        assert reply is not None and reply.attachment is not None
        assert read_attachment(reply.attachment.to_bytes()) == (7, gid)
        assert codec.decode(reply.payload.to_bytes(), "humanoid_league_msgs/srv/ManualPenalize_Response").penalized

        with open_session(bus) as caller_session:
            request_msg = codec.make("humanoid_league_msgs/srv/ManualPenalize_Request", penalize=2)
            assert not call_service(caller_session, "robot1", "manual_penalize", request_msg).penalized
            client_token = (f"@ros2_lv/0/{caller_session.zid()}/*/*/SC/%/%/*/%robot1%manual_penalize/{dds}/"
                            f"{srv_hash}/*")
            wait_for(lambda: any(zenoh.KeyExpr(client_token).intersects(zenoh.KeyExpr(t)) for t in tokens),
                     what="the caller's SC token")
    finally:
        node.shutdown()
        lv.undeclare()
