"""pitchside and a ROS 2 node on one Zenoh bus, no bridge: real sessions through a real router on loopback.

The ROS 2 side is a peer written here from rmw_zenoh's protocol description (docs/design.md of 0.2.x: key
layout, token layout, attachment layout) with raw Zenoh calls, struct and rosbags' CDR, never pitchside's
wire.ros2, so the two sides can only meet if pitchside's module speaks the documented wire.
"""

from __future__ import annotations

import struct
import time
from collections.abc import Iterator

import numpy as np
import pytest
import zenoh
import zenoh.ext
from rosbags.typesys import Stores, get_typestore

from schemas import codec
from tests.support import REPO
from tests.waiting import wait_for
from wire.bus import BusConfig, open_session
from wire.ros2.endpoints import Ros2Client, Ros2Node, Ros2ServiceError
from wire.ros2.graph import Ros2Graph
from wire.ros2.liveliness import EntityKind, NodeInfo
from wire.ros2.qos import Durability, QoS

ROS2 = get_typestore(Stores.ROS2_JAZZY)
JOINT_STATE_HASH = "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e"  # as ROS 2 publishes it
JOINT_STATE_DDS = "sensor_msgs::msg::dds_::JointState_"


def ros2_joint_state(names: list[str], positions: list[float]) -> bytes:
    """A JointState as a ROS 2 node serialises it (rosbags' CDR, encapsulation header included)."""
    msg_type = ROS2.types["sensor_msgs/msg/JointState"]
    header = ROS2.types["std_msgs/msg/Header"](stamp=ROS2.types["builtin_interfaces/msg/Time"](sec=12, nanosec=5),
                                               frame_id="")
    msg = msg_type(header=header, name=names, position=np.array(positions, dtype=np.float64),
                   velocity=np.zeros(0), effort=np.zeros(0))
    return bytes(ROS2.serialize_cdr(msg, "sensor_msgs/msg/JointState"))


def rmw_attachment(sequence_number: int, gid: bytes) -> bytes:
    """design.md: int64 sequence number, int64 source timestamp (ns), 1 byte GID length, 16 bytes GID."""
    return struct.pack("<qqB", sequence_number, time.time_ns(), len(gid)) + gid


@pytest.fixture
def sessions(bus: BusConfig) -> Iterator[tuple[zenoh.Session, zenoh.Session]]:
    """(pitchside's session, the ROS 2 peer's session), both on the test's router."""
    ours, theirs = open_session(bus), open_session(bus)
    yield ours, theirs
    theirs.close()
    ours.close()


def test_pitchside_discovers_a_ros2_robot_and_decodes_its_joint_states(
        sessions: tuple[zenoh.Session, zenoh.Session]) -> None:
    """A Bit-Bots-style robot: its own ROS_DOMAIN_ID (11), root namespace, /joint_states."""
    ours, peer = sessions
    zid = str(peer.zid())
    gid = bytes(range(100, 116))
    lv = peer.liveliness()
    tokens = [lv.declare_token(f"@ros2_lv/11/{zid}/0/0/NN/%/%/ros_control"),
              lv.declare_token(f"@ros2_lv/11/{zid}/0/1/MP/%/%/ros_control/%joint_states/{JOINT_STATE_DDS}/"
                               f"{JOINT_STATE_HASH}/::,10:,:,:,,"),
              lv.declare_token("@ros2_lv/11/not/a/token")]  # a stranger's: counted, never a crash
    graph = Ros2Graph(ours, domain_id=11)
    other_domain = Ros2Graph(ours, domain_id=0)
    try:
        robot = NodeInfo(11, "/", "ros_control")
        wait_for(lambda: robot in graph.nodes(), what="the ROS 2 node in the graph")
        (publisher,) = wait_for(lambda: graph.endpoints_of(robot, EntityKind.PUBLISHER), what="its publisher")
        assert publisher.topic is not None
        assert (publisher.topic.name, publisher.topic.ros_type) == ("/joint_states", "sensor_msgs/msg/JointState")
        assert publisher.topic.type_hash == codec.type_hash("sensor_msgs/JointState") == JOINT_STATE_HASH
        assert publisher.zid == zid and publisher.qos is not None and publisher.qos.depth == 10
        assert graph.topics() == {"/joint_states": {"sensor_msgs/msg/JointState"}}
        assert wait_for(lambda: graph.bad_tokens == 1, what="the stranger's token counted")
        assert other_domain.nodes() == []  # domains stay apart

        received: list[tuple[object, int, bytes]] = []
        dashboard = Ros2Node(ours, NodeInfo(11, "/", "pitchside_dashboard"), node_id=0)
        subscription = dashboard.create_subscription(
            publisher.topic.name, publisher.topic.ros_type, publisher.topic.type_hash,
            lambda payload, att: received.append((codec.decode(payload, "sensor_msgs/JointState"),
                                                  att.sequence_number, att.gid)))
        key = f"11/joint_states/{JOINT_STATE_DDS}/{JOINT_STATE_HASH}"
        payload = ros2_joint_state(["HeadPan", "HeadTilt"], [0.25, -0.5])
        peer.put(key, payload)  # no attachment: rmw_zenoh drops it, so does pitchside
        wait_for(lambda: subscription.dropped == 1, what="the sample without attachment dropped")
        sequence = iter(range(1, 1000))
        wait_for(lambda: received or peer.put(key, payload, attachment=rmw_attachment(next(sequence), gid)),
                 what="a JointState from the ROS 2 node")
        message, sequence_number, sender = received[0]
        assert list(message.name) == ["HeadPan", "HeadTilt"]  # type: ignore[attr-defined]
        assert list(message.position) == [0.25, -0.5]  # type: ignore[attr-defined]
        assert message.header.stamp.sec == 12  # type: ignore[attr-defined]
        assert sequence_number >= 1 and sender == gid
        subscription.close()
        dashboard.close()
    finally:
        graph.close()
        other_domain.close()
        for token in tokens:
            token.undeclare()


def test_a_ros2_node_sees_pitchsides_node_and_takes_its_samples(
        sessions: tuple[zenoh.Session, zenoh.Session]) -> None:
    """pitchside's robot1 (a namespace in domain 0) as a ROS 2 subscriber checks it: token, key, attachment."""
    ours, peer = sessions
    seen_tokens: set[str] = set()

    def on_token(sample: zenoh.Sample) -> None:  # a graph cache's bookkeeping: PUT adds, DELETE removes
        if sample.kind == zenoh.SampleKind.PUT:
            seen_tokens.add(str(sample.key_expr))
        else:
            seen_tokens.discard(str(sample.key_expr))

    lv_subscriber = peer.liveliness().declare_subscriber("@ros2_lv/0/**", on_token, history=True)
    samples: list[zenoh.Sample] = []
    key = f"0/robot1/joint_states/{JOINT_STATE_DDS}/{JOINT_STATE_HASH}"
    data_subscriber = peer.declare_subscriber(key, samples.append)
    node = Ros2Node(ours, NodeInfo(0, "/robot1", "cm730"), node_id=0)
    try:
        publisher = node.create_publisher("/robot1/joint_states", "sensor_msgs/msg/JointState",
                                          codec.type_hash("sensor_msgs/JointState"))
        zid = str(ours.zid())
        expected_node = f"@ros2_lv/0/{zid}/0/0/NN/%/%robot1/cm730"
        expected_publisher = (f"@ros2_lv/0/{zid}/0/1/MP/%/%robot1/cm730/%robot1%joint_states/{JOINT_STATE_DDS}/"
                              f"{JOINT_STATE_HASH}/::,10:,:,:,,")
        wait_for(lambda: {expected_node, expected_publisher} <= seen_tokens, what=lambda: f"tokens, saw {seen_tokens}")

        sent = codec.make("sensor_msgs/JointState", name=["LKnee", "RKnee"], position=[1.0, -1.0])
        before_ns = time.time_ns()
        attachments = []
        wait_for(lambda: samples or attachments.append(publisher.publish(codec.encode(sent))),
                 what="pitchside's JointState")
        assert attachments[0].sequence_number == 1  # from 1, as rmw_zenoh counts
        sample = samples[0]
        assert str(sample.key_expr) == key
        assert sample.attachment is not None
        raw = sample.attachment.to_bytes()
        assert len(raw) == 33
        sequence_number, stamp_ns, gid_length = struct.unpack_from("<qqB", raw)
        assert sequence_number >= 1 and gid_length == 16 and raw[17:] == publisher.gid
        assert before_ns <= stamp_ns <= time.time_ns()
        message = ROS2.deserialize_cdr(sample.payload.to_bytes(), "sensor_msgs/msg/JointState")
        assert list(message.name) == ["LKnee", "RKnee"] and list(message.position) == [1.0, -1.0]
        # one more per sample, with no gap (early ones may go out before the peer's subscriber is routed)
        numbers = [struct.unpack_from("<q", s.attachment.to_bytes())[0] for s in samples if s.attachment]
        assert numbers == list(range(numbers[0], numbers[0] + len(numbers)))

        publisher.close()  # its token goes: ROS 2's graph forgets the publisher, keeps the node
        wait_for(lambda: expected_publisher not in seen_tokens, what="the publisher's token withdrawn")
        assert expected_node in seen_tokens
    finally:
        node.close()
        data_subscriber.undeclare()
        lv_subscriber.undeclare()


def test_the_guides_python_example_lists_a_ros2_robot(sessions: tuple[zenoh.Session, zenoh.Session],
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """docs/guides/ros2.md's snippet, run as written against a ROS 2 node in domain 11."""
    ours, peer = sessions
    zid = str(peer.zid())
    tokens = [peer.liveliness().declare_token(f"@ros2_lv/11/{zid}/0/0/NN/%/%/ros_control"),
              peer.liveliness().declare_token(
                  f"@ros2_lv/11/{zid}/0/1/MP/%/%/ros_control/%joint_states/{JOINT_STATE_DDS}/{JOINT_STATE_HASH}/"
                  "::,10:,:,:,,")]
    text = (REPO / "docs" / "guides" / "ros2.md").read_text()
    snippet = text.split("```python", 1)[1].split("\n", 1)[1].split("```", 1)[0]  # the fence has a title
    probe = Ros2Graph(ours, domain_id=11)
    try:
        wait_for(lambda: probe.endpoints_of(NodeInfo(11, "/", "ros_control"), EntityKind.PUBLISHER),
                 what="the robot's publisher")
        exec(compile(snippet, "docs/guides/ros2.md", "exec"), {"session": ours})
        assert capsys.readouterr().out.split() == ["/ros_control", "/joint_states", "sensor_msgs/msg/JointState",
                                                   JOINT_STATE_HASH]
    finally:
        probe.close()
        for token in tokens:
            token.undeclare()


ADD_TWO_INTS = "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a"  # rmw_zenoh's design.md
ADD_TWO_INTS_DDS = "example_interfaces::srv::dds_::AddTwoInts_"
CDR_LE = b"\x00\x01\x00\x00"  # the encapsulation header of little-endian CDR


def test_services_both_ways_as_rmw_zenoh_calls_and_answers(sessions: tuple[zenoh.Session, zenoh.Session]) -> None:
    """AddTwoInts (int64 a, int64 b -> int64 sum): pitchside serves a ROS 2 client written from design.md, and
    calls a ROS 2 server written from it; requests and replies carry the attachment design.md describes."""
    ours, peer = sessions
    node = Ros2Node(ours, NodeInfo(2, "/robot1", "calculator"), node_id=0)

    def add_two_ints(request: bytes, _attachment: object) -> bytes:
        return CDR_LE + struct.pack("<q", sum(struct.unpack_from("<qq", request, 4)))

    add = node.create_service("/robot1/add_two_ints", "example_interfaces/srv/AddTwoInts", ADD_TWO_INTS, add_two_ints)
    key = f"2/robot1/add_two_ints/{ADD_TWO_INTS_DDS}/{ADD_TWO_INTS}"
    seen: set[str] = set()
    lv = peer.liveliness().declare_subscriber("@ros2_lv/2/**", lambda s: seen.add(str(s.key_expr)), history=True)
    peer_server = None
    try:
        wait_for(lambda: any(f"/SS/%/%robot1/calculator/%robot1%add_two_ints/{ADD_TWO_INTS_DDS}/{ADD_TWO_INTS}/"
                             in token for token in seen), what="the service's SS token")
        client_gid = bytes(range(200, 216))

        def ask(attachment: bytes | None, timeout_s: float = 5.0) -> list[zenoh.Sample]:
            replies = peer.get(key, target=zenoh.QueryTarget.ALL_COMPLETE, payload=CDR_LE + struct.pack("<qq", 2, 40),
                               attachment=attachment, timeout=timeout_s)
            return [r.ok for r in replies if r.ok is not None]

        (reply,) = wait_for(lambda: ask(rmw_attachment(7, client_gid)), what="a reply from pitchside's service")
        assert reply.attachment is not None
        assert struct.unpack_from("<q", reply.payload.to_bytes(), 4) == (42,)
        sequence_number, _, gid_length = struct.unpack_from("<qqB", reply.attachment.to_bytes())
        assert (sequence_number, gid_length, reply.attachment.to_bytes()[17:]) == (7, 16, client_gid)
        assert ask(None, timeout_s=0.3) == [] and add.dropped == 1  # no attachment: unanswered, as in rmw_zenoh

        # the other way: a ROS 2 server (a complete queryable replying with the request's attachment)
        def serve(query: zenoh.Query) -> None:
            assert query.attachment is not None and query.payload is not None
            request = query.attachment.to_bytes()
            a, b = struct.unpack_from("<qq", query.payload.to_bytes(), 4)
            query.reply(query.key_expr, CDR_LE + struct.pack("<q", a * b),
                        attachment=struct.pack("<qqB", struct.unpack_from("<q", request)[0], time.time_ns(), 16)
                        + request[17:])

        peer_key = f"2/multiply/{ADD_TWO_INTS_DDS}/{ADD_TWO_INTS}"
        peer_server = peer.declare_queryable(peer_key, serve, complete=True)
        client = node.create_client("/multiply", "example_interfaces/srv/AddTwoInts", ADD_TWO_INTS)
        response, attachment = wait_for(lambda: _call_or_none(client, CDR_LE + struct.pack("<qq", 6, 7)),
                                        what="the ROS 2 server's reply")
        assert struct.unpack_from("<q", response, 4) == (42,)
        assert attachment.gid == client.gid and attachment.sequence_number >= 1
        client.close()

        def broken(_request: bytes, _attachment: object) -> bytes:
            raise ValueError("a request this server cannot take")

        failing = node.create_service("/robot1/broken", "example_interfaces/srv/AddTwoInts", ADD_TWO_INTS, broken)
        caller = node.create_client("/robot1/broken", "example_interfaces/srv/AddTwoInts", ADD_TWO_INTS)
        with pytest.raises(Ros2ServiceError, match="cannot take"):
            caller.call(CDR_LE + bytes(16))
        assert failing.failed == 1  # answered with an error, the server still up
        caller.close()
        failing.close()
    finally:
        if peer_server is not None:
            peer_server.undeclare()
        lv.undeclare()
        add.close()
        node.close()


def _call_or_none(client: Ros2Client, request: bytes) -> tuple[bytes, object] | None:
    try:
        return client.call(request, timeout_s=1.0)
    except Ros2ServiceError:
        return None  # the queryable not routed to us yet


STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"


def ros2_string(text: str) -> bytes:
    return bytes(ROS2.serialize_cdr(ROS2.types["std_msgs/msg/String"](data=text), "std_msgs/msg/String"))


def test_latched_topics_reach_late_joiners_both_ways(sessions: tuple[zenoh.Session, zenoh.Session]) -> None:
    """Transient local as design.md describes it: the publisher an AdvancedPublisher with a cache, the subscriber
    an AdvancedSubscriber that queries it; the subscriber joins after the message was published."""
    ours, peer = sessions
    node = Ros2Node(ours, NodeInfo(0, "/robot1", "robot_state_publisher"), node_id=0)
    latched = QoS(durability=Durability.TRANSIENT_LOCAL, depth=1)
    publisher = node.create_publisher("/robot1/robot_description", "std_msgs/msg/String", STRING_HASH, latched)
    publisher.publish(ros2_string("<robot name='robot1'/>"))
    got: list[zenoh.Sample] = []
    late = zenoh.ext.declare_advanced_subscriber(
        peer, f"0/robot1/robot_description/std_msgs::msg::dds_::String_/{STRING_HASH}", got.append,
        history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=1), subscriber_detection=True)
    theirs = None
    try:
        wait_for(lambda: got, what="the latched robot_description at a late ROS 2 subscriber")
        assert ROS2.deserialize_cdr(got[0].payload.to_bytes(), "std_msgs/msg/String").data == "<robot name='robot1'/>"
        assert got[0].attachment is not None and got[0].attachment.to_bytes()[17:] == publisher.gid

        theirs = zenoh.ext.declare_advanced_publisher(
            peer, f"0/tf_static_names/std_msgs::msg::dds_::String_/{STRING_HASH}",
            cache=zenoh.ext.CacheConfig(max_samples=1), publisher_detection=True)
        theirs.put(ros2_string("base_link"), attachment=rmw_attachment(1, bytes(16)))
        received: list[str] = []
        subscription = node.create_subscription(
            "/tf_static_names", "std_msgs/msg/String", STRING_HASH,
            lambda payload, _att: received.append(ROS2.deserialize_cdr(payload, "std_msgs/msg/String").data), latched)
        wait_for(lambda: received == ["base_link"], what="a latched ROS 2 message at a late pitchside subscriber")
        subscription.close()
    finally:
        if theirs is not None:
            theirs.undeclare()
        late.undeclare()
        publisher.close()
        node.close()


def test_pitchsides_runtime_nodes_speak_the_data_path_of_ros2(bus: BusConfig,
                                                               sessions: tuple[zenoh.Session, zenoh.Session]) -> None:
    """A runtime node (robot_nodes.runtime.Node) of robot1: its joint_states reach a ROS 2 subscriber on
    rmw_zenoh's key with the attachment, and a ROS 2 publisher's cmd_vel reaches its subscription."""
    from robot_nodes.runtime import Node

    _, peer = sessions
    got: list[zenoh.Sample] = []
    peer_subscriber = peer.declare_subscriber(f"0/robot1/joint_states/{JOINT_STATE_DDS}/{JOINT_STATE_HASH}",
                                              got.append)
    node = Node("robot1", bus=bus).start()
    commands: list[object] = []
    twist_hash = codec.type_hash("geometry_msgs/msg/Twist")
    try:
        joint_states = node.publisher("joint_states")
        node.subscribe("cmd_vel", commands.append)
        wait_for(lambda: got or joint_states.publish(codec.make("sensor_msgs/JointState", name=["LKnee"],
                                                                position=[0.5])),
                 what="the node's joint_states at the ROS 2 subscriber")
        assert got[0].attachment is not None
        sequence_number, _, gid_length = struct.unpack_from("<qqB", got[0].attachment.to_bytes())
        assert sequence_number >= 1 and gid_length == 16
        assert got[0].attachment.to_bytes()[17:] == joint_states.entity.gid
        assert list(ROS2.deserialize_cdr(got[0].payload.to_bytes(), "sensor_msgs/msg/JointState").name) == ["LKnee"]

        Twist, Vector3 = ROS2.types["geometry_msgs/msg/Twist"], ROS2.types["geometry_msgs/msg/Vector3"]
        message = Twist(linear=Vector3(x=0.2, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=0.1))
        drive = bytes(ROS2.serialize_cdr(message, "geometry_msgs/msg/Twist"))
        key = f"0/robot1/cmd_vel/geometry_msgs::msg::dds_::Twist_/{twist_hash}"
        sequence = iter(range(1, 1000))
        wait_for(lambda: commands or peer.put(key, drive, attachment=rmw_attachment(next(sequence), bytes(16))),
                 what="a ROS 2 node's cmd_vel at the pitchside node")
        assert commands[0].linear.x == 0.2 and commands[0].angular.z == 0.1  # type: ignore[attr-defined]
    finally:
        node.shutdown()
        peer_subscriber.undeclare()


def test_ros2s_graph_lists_pitchsides_runtime_nodes(bus: BusConfig,
                                                   sessions: tuple[zenoh.Session, zenoh.Session]) -> None:
    """What ``ros2 node list``, ``ros2 topic list -t`` and ``ros2 node info`` read: the NN, MP, MS and SS tokens of
    a runtime node, read by a ROS 2 graph cache written in the test (token strings split as design.md lays them
    out), exactly: nothing missing, nothing of pitchside's own."""
    from robot_nodes.runtime import Node

    _, peer = sessions
    tokens: set[str] = set()

    def on_token(sample: zenoh.Sample) -> None:
        (tokens.add if sample.kind == zenoh.SampleKind.PUT else tokens.discard)(str(sample.key_expr))

    graph = peer.liveliness().declare_subscriber("@ros2_lv/0/**", on_token, history=True)
    node = Node("robot1", bus=bus).start()
    try:
        node.publisher("joint_states")
        node.subscribe("cmd_vel", lambda _msg: None)
        node.service("manual_penalize", lambda _request: None)  # type: ignore[arg-type,return-value]

        def listed() -> dict[str, set[tuple[str, str, str, str]]]:
            seen: dict[str, set[tuple[str, str, str, str]]] = {}
            for token in list(tokens):
                parts = token.split("/")  # @ros2_lv domain zid nid eid kind enclave ns node [name type hash qos]
                fq_node = parts[7].replace("%", "/") + "/" + parts[8]
                entry = seen.setdefault(fq_node, set())
                if parts[5] != "NN":
                    entry.add((parts[5], parts[9].replace("%", "/"), parts[10], parts[12]))
            return seen

        wanted = {("MP", "/robot1/joint_states", JOINT_STATE_DDS, "::,10:,:,:,,"),
                  ("MP", "/robot1/diagnostics", "diagnostic_msgs::msg::dds_::DiagnosticArray_", "::,10:,:,:,,"),
                  # ROS 2's /rosout with rcl's QoS (transient local, depth 1000, lifespan 10 s), as design.md has it
                  ("MP", "/rosout", "rcl_interfaces::msg::dds_::Log_", ":1:,1000:,:10,0:,,"),
                  ("MS", "/robot1/cmd_vel", "geometry_msgs::msg::dds_::Twist_", "::,10:,:,:,,"),
                  ("SS", "/robot1/manual_penalize", "humanoid_league_msgs::srv::dds_::ManualPenalize_",
                   "::,10:,:,:,,"),
                  # every node's parameter changes and parameter services, with rclcpp's parameter QoS (depth 1000)
                  ("MP", "/parameter_events", "rcl_interfaces::msg::dds_::ParameterEvent_", "::,1000:,:,:,,")}
        wanted |= {("SS", f"/robot1/node/{name}", f"rcl_interfaces::srv::dds_::{ros_type}_", "::,1000:,:,:,,")
                   for name, ros_type in [("list_parameters", "ListParameters"),
                                          ("describe_parameters", "DescribeParameters"),
                                          ("get_parameters", "GetParameters"), ("set_parameters", "SetParameters"),
                                          ("set_parameters_atomically", "SetParametersAtomically"),
                                          ("get_parameter_types", "GetParameterTypes")]}
        # what rcl_interfaces has no field for: values with their revisions, the checked set, the YAML file
        wanted |= {("SS", f"/robot1/node/pitchside/{name}", f"pitchside_msgs::srv::dds_::{ros_type}_", "::,1000:,:,:,,")
                   for name, ros_type in [("get_parameter_states", "GetParameterStates"),
                                          ("set_parameters_checked", "SetParametersChecked"),
                                          ("parameter_file", "ParameterFile")]}
        wait_for(lambda: listed().get("/robot1/node") == wanted,
                 what=lambda: f"the node's tokens: {listed().get('/robot1/node')}")
        assert set(listed()) == {"/robot1/node"}  # ros2 node list
        assert not any(token.startswith("pitchside/") for token in tokens)
        node.shutdown()
        wait_for(lambda: "/robot1/node" not in listed(), what="the node gone from the graph with its tokens")
    finally:
        node.shutdown()
        graph.undeclare()


LOG_HASH = "RIHS01_e28ce254ca8abc06abf92773b74602cdbf116ed34fbaf294fb9f81da9f318eac"  # rcl_interfaces/msg/Log


def test_a_runtime_nodes_log_reaches_a_ros2_subscriber_of_rosout(bus: BusConfig,
                                                               sessions: tuple[zenoh.Session, zenoh.Session]) -> None:
    """ROS 2's /rosout, one topic for every node of the domain: a pitchside node's records reach a ROS 2 subscriber
    of /rosout (as ``ros2 topic echo /rosout`` subscribes), named ``<robot>.<node>`` as rclcpp names a namespaced
    node's logger; a subscriber that joins later gets the earlier records (rcl's transient local /rosout)."""
    import logging

    from robot_nodes.runtime import Node

    _, peer = sessions
    key = f"0/rosout/rcl_interfaces::msg::dds_::Log_/{LOG_HASH}"
    live: list[zenoh.Sample] = []
    subscriber = peer.declare_subscriber(key, live.append)
    node = Node("robot1", bus=bus).start()
    node.log.setLevel(logging.INFO)
    late = None
    try:
        wait_for(lambda: node.log.warning("servo 7 hot") or live, what="a record on /rosout at a ROS 2 subscriber")
        record = ROS2.deserialize_cdr(live[0].payload.to_bytes(), "rcl_interfaces/msg/Log")
        assert record.name == "robot1.node" and record.msg == "servo 7 hot" and record.level == 30  # WARN
        assert live[0].attachment is not None and live[0].attachment.to_bytes()[17:] == \
            node._rosout_publisher.entity.gid
        earlier: list[zenoh.Sample] = []
        late = zenoh.ext.declare_advanced_subscriber(
            peer, key, earlier.append, subscriber_detection=True,
            history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=1000))
        wait_for(lambda: earlier, what="the earlier records at a late transient-local subscriber")
        assert any(ROS2.deserialize_cdr(s.payload.to_bytes(), "rcl_interfaces/msg/Log").msg == "servo 7 hot"
                   for s in earlier)
    finally:
        if late is not None:
            late.undeclare()
        subscriber.undeclare()
        node.shutdown()


def test_the_robot_of_a_rosout_record_is_its_logger_names_namespace() -> None:
    """The dashboard's live source tells robots apart on /rosout by the logger name; a ROS 2 node of the root
    namespace names no robot, and a message that does not decode is a clear error."""
    from schemas import encode, make
    from wire import keys

    key = f"0/rosout/rcl_interfaces::msg::dds_::Log_/{LOG_HASH}"

    def record(name: str) -> bytes:
        return encode(make("rcl_interfaces/msg/Log", name=name, msg="hi", level=20))

    assert keys.split_sample(key, record("robot2.walking")) == ("robot2", "rosout")
    assert keys.split_sample(key, record("robot2.walking.engine")) == ("robot2", "rosout")  # a child logger
    assert keys.split_sample(keys.topic_key("robot3", "joint_states"), b"") == ("robot3", "joint_states")
    with pytest.raises(ValueError, match="names no robot"):
        keys.split_sample(key, record("talker"))
    with pytest.raises(ValueError, match="/rosout"):
        keys.split_sample(key, b"\x00\x01\x00\x00\x01")
    with pytest.raises(ValueError, match="the table's rosout"):
        keys.split_sample(f"0/rosout/std_msgs::msg::dds_::String_/{STRING_HASH}", b"")
