"""rmw_zenoh's wire (wire/ros2): data keys, liveliness tokens, QoS strings and the attachment, compared with the
formats in rmw_zenoh_cpp 0.2.x's docs/design.md and with tokens a running rmw_zenoh talker declared; bad input
raises Ros2WireError."""

from __future__ import annotations

import pytest
import zenoh.ext
from hypothesis import given
from hypothesis import strategies as st

from schemas.codec import type_hash
from wire.ros2 import (
    Attachment,
    Entity,
    EntityKind,
    NodeInfo,
    QoS,
    Ros2WireError,
    TopicKey,
    decode_attachment,
    domain_id_from_env,
    fully_qualified_name,
    keyexpr_to_qos,
    parse_token,
    parse_topic_key,
    qos_to_keyexpr,
)
from wire.ros2.qos import DEFAULT_10, ROSOUT, Durability, Reliability

STRING = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
ADD_TWO_INTS = "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a"
LOG = "RIHS01_e28ce254ca8abc06abf92773b74602cdbf116ed34fbaf294fb9f81da9f318eac"
PARAMETER_EVENT = "RIHS01_043e627780fcad87a22d225bc2a037361dba713fca6a6b9f4b869a5aa0393204"


@pytest.mark.parametrize(("key", "domain", "name", "ros_type", "type_hash_"), [
    # docs/design.md "Topic and Service name mapping to Zenoh key expressions"
    (f"0/chatter/std_msgs::msg::dds_::String_/{STRING}", 0, "/chatter", "std_msgs/msg/String", STRING),
    (f"0/robot1/chatter/std_msgs::msg::dds_::String_/{STRING}", 0, "/robot1/chatter", "std_msgs/msg/String", STRING),
    (f"2/add_two_ints/example_interfaces::srv::dds_::AddTwoInts_/{ADD_TWO_INTS}", 2, "/add_two_ints",
     "example_interfaces/srv/AddTwoInts", ADD_TWO_INTS),
])
def test_data_keys_as_rmw_zenoh_documents_them(key: str, domain: int, name: str, ros_type: str,
                                               type_hash_: str) -> None:
    assert TopicKey(domain, name, ros_type, type_hash_).keyexpr == key
    assert parse_topic_key(key) == TopicKey(domain, name, ros_type, type_hash_)


def test_a_pitchside_topic_key_carries_its_computed_hash() -> None:
    key = TopicKey(0, fully_qualified_name("/robot1", "joint_states"), "sensor_msgs/msg/JointState",
                   type_hash("sensor_msgs/JointState"))
    assert key.keyexpr == ("0/robot1/joint_states/sensor_msgs::msg::dds_::JointState_/"
                           "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e")
    assert fully_qualified_name("/", "joint_states") == "/joint_states"
    assert fully_qualified_name("/robot1", "/tf") == "/tf"


ZID_LISTENER = "aac3178e146ba6f1fc6e6a4085e77f21"
ZID_TALKER = "ae35e834a80cb2398c738e251c05e716"
ROOT = "/"

TOKENS = [
    # docs/design.md "Graph Cache": the demo_nodes_cpp examples
    (f"@ros2_lv/0/{ZID_LISTENER}/0/0/NN/%/%/listener",
     Entity(ZID_LISTENER, 0, 0, EntityKind.NODE, NodeInfo(0, ROOT, "listener"))),
    (f"@ros2_lv/0/{ZID_LISTENER}/0/10/MS/%/%/listener/%chatter/std_msgs::msg::dds_::String_/{STRING}/::,10:,:,:,,",
     Entity(ZID_LISTENER, 0, 10, EntityKind.SUBSCRIPTION, NodeInfo(0, ROOT, "listener"),
            TopicKey(0, "/chatter", "std_msgs/msg/String", STRING), DEFAULT_10)),
    ("@ros2_lv/0/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/"
     f"{STRING}/::,7:,:,:,,",
     Entity("8b20917502ee955ac4476e0266340d5c", 0, 10, EntityKind.PUBLISHER, NodeInfo(0, ROOT, "talker"),
            TopicKey(0, "/chatter", "std_msgs/msg/String", STRING), QoS(depth=7))),
    ("@ros2_lv/0/f9980ee0495eaafb3e38f0d19e2eae12/0/10/SS/%/%/add_two_ints_server/%add_two_ints/"
     f"example_interfaces::srv::dds_::AddTwoInts_/{ADD_TWO_INTS}/::,10:,:,:,,",
     Entity("f9980ee0495eaafb3e38f0d19e2eae12", 0, 10, EntityKind.SERVICE, NodeInfo(0, ROOT, "add_two_ints_server"),
            TopicKey(0, "/add_two_ints", "example_interfaces/srv/AddTwoInts", ADD_TWO_INTS), DEFAULT_10)),
    ("@ros2_lv/0/e1dc8d1b45ae8717fce78689cc655685/0/10/SC/%/%/add_two_ints_client/%add_two_ints/"
     f"example_interfaces::srv::dds_::AddTwoInts_/{ADD_TWO_INTS}/::,10:,:,:,,",
     Entity("e1dc8d1b45ae8717fce78689cc655685", 0, 10, EntityKind.CLIENT, NodeInfo(0, ROOT, "add_two_ints_client"),
            TopicKey(0, "/add_two_ints", "example_interfaces/srv/AddTwoInts", ADD_TWO_INTS), DEFAULT_10)),
    # declared by a running rmw_zenoh talker: /rosout (rcl's rosout QoS) and /parameter_events
    (f"@ros2_lv/0/{ZID_TALKER}/0/1/MP/%/%/talker/%rosout/rcl_interfaces::msg::dds_::Log_/{LOG}/:1:,1000:,:10,0:,,",
     Entity(ZID_TALKER, 0, 1, EntityKind.PUBLISHER, NodeInfo(0, ROOT, "talker"),
            TopicKey(0, "/rosout", "rcl_interfaces/msg/Log", LOG), ROSOUT)),
    (f"@ros2_lv/0/{ZID_TALKER}/0/9/MS/%/%/talker/%parameter_events/rcl_interfaces::msg::dds_::ParameterEvent_/"
     f"{PARAMETER_EVENT}/::,1000:,:,:,,",
     Entity(ZID_TALKER, 0, 9, EntityKind.SUBSCRIPTION, NodeInfo(0, ROOT, "talker"),
            TopicKey(0, "/parameter_events", "rcl_interfaces/msg/ParameterEvent", PARAMETER_EVENT),
            QoS(depth=1000))),
]


@pytest.mark.parametrize(("token", "entity"), TOKENS)
def test_tokens_as_rmw_zenoh_writes_them(token: str, entity: Entity) -> None:
    assert entity.token == token
    assert parse_token(token) == entity


def test_a_namespaced_node_and_its_topic_mangle_every_slash() -> None:
    node = NodeInfo(11, "/robot1", "hcm")
    entity = Entity(ZID_TALKER, 3, 7, EntityKind.PUBLISHER, node,
                    TopicKey(11, "/robot1/robot_state", "humanoid_league_msgs/msg/RobotControlState",
                             type_hash("humanoid_league_msgs/msg/RobotControlState")), QoS(depth=10))
    assert entity.token.startswith(f"@ros2_lv/11/{ZID_TALKER}/3/7/MP/%/%robot1/hcm/%robot1%robot_state/"
                                   "humanoid_league_msgs::msg::dds_::RobotControlState_/RIHS01_")
    assert entity.token.endswith("/::,10:,:,:,,")
    assert parse_token(entity.token) == entity
    assert node.fully_qualified_name == "/robot1/hcm"


def test_rosout_qos_is_rcls_and_defaults_are_left_empty() -> None:
    assert qos_to_keyexpr(ROSOUT) == ":1:,1000:,:10,0:,,"
    assert qos_to_keyexpr(QoS()) == "::,:,:,:,,"
    assert keyexpr_to_qos("::,:,:,:,,") == QoS()
    best_effort = QoS(reliability=Reliability.BEST_EFFORT, durability=Durability.TRANSIENT_LOCAL, depth=5)
    assert qos_to_keyexpr(best_effort) == "2:1:,5:,:,:,,"
    assert keyexpr_to_qos("2:1:,5:,:,:,,") == best_effort


@given(st.builds(QoS, reliability=st.sampled_from(Reliability), durability=st.sampled_from(Durability),
                 depth=st.integers(0, 2**32), deadline_s=st.integers(0, 2**40), lifespan_ns=st.integers(0, 10**9)))
def test_qos_round_trips(qos: QoS) -> None:
    assert keyexpr_to_qos(qos_to_keyexpr(qos)) == qos


def test_the_attachment_is_what_zenoh_ext_serialises() -> None:
    """zenoh-ext's own serializer (what rmw_zenoh's AttachmentData uses) as the oracle: int64, int64, 16 bytes."""
    gid = bytes(range(16, 32))
    expected = zenoh.ext.z_serialize((zenoh.ext.Int64(7), zenoh.ext.Int64(1_700_000_000_123_456_789), gid))
    attachment = Attachment(7, 1_700_000_000_123_456_789, gid)
    assert attachment.encode() == expected.to_bytes()
    assert len(attachment.encode()) == 33
    assert decode_attachment(expected.to_bytes()) == attachment


def test_gids_are_16_bytes_and_differ_per_entity() -> None:
    gids = {entity.gid for _, entity in TOKENS}
    assert len(gids) == len(TOKENS) and all(len(gid) == 16 for gid in gids)


@pytest.mark.parametrize(("token", "complaint"), [
    ("@ros2_lv/0/abc/0/0/NN/%/%", "at least 9"),
    ("@ros2_lv/0/abc/0/0/XX/%/%/talker", "no entity kind"),
    ("@ros2_lv/x/abc/0/0/NN/%/%/talker", "domain id"),
    ("@ros2_lv/²/abc/0/0/NN/%/%/talker", "domain id"),
    ("@other/0/abc/0/0/NN/%/%/talker", "does not start with @ros2_lv"),
    ("@ros2_lv/0/abc/0/0/NN/%//talker", "empty part"),
    ("@ros2_lv/0/abc/0/1/MP/%/%/talker/%chatter", "not 13"),
    (f"@ros2_lv/0/abc/0/1/MP/%/%/talker/%chatter/std_msgs/{STRING}/::,:,:,:,,", "not a DDS type"),
    ("@ros2_lv/0/abc/0/1/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/RIHS01_12/::,:,:,:,,",
     "not a RIHS01"),
    (f"@ros2_lv/0/abc/0/1/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/{STRING}/::,:", "not 6"),
    (f"@ros2_lv/0/abc/0/1/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/{STRING}/9::,:,:,:,,",
     "no reliability"),
    (f"@ros2_lv/0/abc/0/1/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/{STRING}/::,-1:,:,:,,", "depth"),
    ("@ros2_lv/0/abc/0/1/MP/%/%/talker/%chat-ter/std_msgs::msg::dds_::String_/"
     f"{STRING}/::,:,:,:,,", "not a ROS 2 name token"),
])
def test_tokens_that_do_not_parse_say_why(token: str, complaint: str) -> None:
    with pytest.raises(Ros2WireError, match=complaint):
        parse_token(token)


def test_bad_keys_attachments_and_domains_raise_the_typed_error() -> None:
    with pytest.raises(Ros2WireError, match="at least 4"):
        parse_topic_key("0/chatter/std_msgs::msg::dds_::String_")
    with pytest.raises(Ros2WireError, match="domain"):
        parse_topic_key(f"zero/chatter/std_msgs::msg::dds_::String_/{STRING}")
    with pytest.raises(Ros2WireError, match="33"):
        decode_attachment(b"\x01" * 20)
    with pytest.raises(Ros2WireError, match="GID length"):
        decode_attachment(bytes(16) + b"\x08" + bytes(16))
    with pytest.raises(Ros2WireError, match="ROS_DOMAIN_ID"):
        domain_id_from_env({"ROS_DOMAIN_ID": "eleven"})
    assert domain_id_from_env({"ROS_DOMAIN_ID": "11"}) == 11
    assert domain_id_from_env({}) == 0
    with pytest.raises(Ros2WireError, match="name token"):
        fully_qualified_name("/robot 1", "joint_states")


@given(st.binary(max_size=64))
def test_any_attachment_bytes_decode_or_raise_the_typed_error(data: bytes) -> None:
    try:
        attachment = decode_attachment(data)
    except Ros2WireError:
        return
    assert attachment.encode() == data


@given(st.text(max_size=200))
def test_any_token_text_parses_or_raises_the_typed_error(text: str) -> None:
    try:
        entity = parse_token(text)
    except Ros2WireError:
        return
    assert parse_token(entity.token) == entity


def test_every_topic_and_service_of_the_table_has_a_ros2_key() -> None:
    """The whole topic table can move onto rmw_zenoh's wire: valid names, hashable types, and back."""
    from schemas import SERVICES, TOPICS
    from wire.ros2 import robots

    for topic in TOPICS:
        key = robots.topic_key("robot1", topic, domain_id=3)
        assert parse_topic_key(key.keyexpr) == key
        if TOPICS[topic].root:  # ROS 2's /rosout: one topic of every robot, in no robot's namespace
            assert key.keyexpr.startswith(f"3/{topic}/") and robots.root_topic(key) == topic
            continue
        assert key.keyexpr.startswith(f"3/robot1/{topic}/")
        assert robots.robot_and_topic(key) == ("robot1", topic) and robots.root_topic(key) is None
    for service in SERVICES:
        assert "::srv::dds_::" in robots.service_key("robot1", service).keyexpr
    assert robots.topic_key("amy", "imu/data").keyexpr == (
        "0/amy/imu/data/sensor_msgs::msg::dds_::Imu_/" + type_hash("sensor_msgs/msg/Imu"))
    # /rosout as every ROS 2 node has it: the key and hash from rmw_zenoh's design notes and issue 44
    assert robots.topic_key("amy", "rosout").keyexpr == (
        "0/rosout/rcl_interfaces::msg::dds_::Log_/"
        "RIHS01_e28ce254ca8abc06abf92773b74602cdbf116ed34fbaf294fb9f81da9f318eac")
    assert qos_to_keyexpr(robots.topic_qos("rosout")) == ":1:,1000:,:10,0:,,"
    assert qos_to_keyexpr(robots.topic_qos("robot_description")) == ":1:,1:,:,:,,"
    assert robots.logger_name("robot1", "hcm") == "robot1.hcm"
    assert robots.robot_of_logger("robot1.hcm") == "robot1" and robots.robot_of_logger("talker") is None


def test_robot_ids_ros2_cannot_carry_and_keys_of_other_types_are_refused() -> None:
    from wire.ros2 import robots

    for robot in ("robot-1", "1robot"):  # valid pitchside ids, no ROS 2 namespace
        with pytest.raises(Ros2WireError, match="no ROS 2 namespace"):
            robots.topic_key(robot, "joint_states")
    stranger = TopicKey(0, "/robot1/joint_states", "std_msgs/msg/String", STRING)
    with pytest.raises(Ros2WireError, match="the table's joint_states"):
        robots.robot_and_topic(stranger)
    with pytest.raises(Ros2WireError, match="not in a robot's namespace"):
        robots.robot_and_topic(TopicKey(11, "/joint_states", "sensor_msgs/msg/JointState",
                                        type_hash("sensor_msgs/JointState")))
    with pytest.raises(Ros2WireError, match="not a topic of the table"):
        robots.robot_and_topic(TopicKey(0, "/robot1/chatter", "std_msgs/msg/String", STRING))
