"""Team profiles, team files, domains and the route of a ROS 2 data key to the dashboard (server.profiles): the pure
parts, against the Bit-Bots' real interface definitions (tests/data/ros2_interfaces)."""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from schemas import codec
from schemas.interface_folder import register_interfaces
from server.profiles.images import ImageEncodingError, jpeg_of
from server.profiles.profile import ProfileError, load_profile, profile_from
from server.profiles.routes import Refusal, RouteRefused
from server.profiles.routes import route as route_of
from server.profiles.team import Ros2Setup, load_team, parse_domains
from server.profiles.translate import translate
from server.sources.live import robot_of_log
from tests.support import TESTDATA
from wire.ros2.keys import TopicKey

INTERFACES = TESTDATA / "ros2_interfaces"


@pytest.fixture(scope="module", autouse=True)
def bitbots_types() -> None:
    register_interfaces(INTERFACES)


def key(domain: int, name: str, ros_type: str, type_hash: str | None = None) -> str:
    return TopicKey(domain, name, ros_type, type_hash or codec.type_hash(ros_type)).keyexpr


def test_domains_as_the_flag_takes_them() -> None:
    assert parse_domains("0,11-16") == (0, 11, 12, 13, 14, 15, 16)
    assert parse_domains(" 3 , 3,1") == (1, 3)
    for bad in ("", "a", "11-", "16-11", "0,233", "-1"):
        with pytest.raises(ValueError, match="ROS 2 domains"):
            parse_domains(bad)


def test_team_file(tmp_path: Path) -> None:
    team = tmp_path / "team.yaml"
    team.write_text("11: amy\n12: rory\n")
    assert load_team(team) == {11: "amy", 12: "rory"}
    for text, said in (("amy: 11\n", "not a ROS 2 domain id"), ("11: '<b>'\n", "must be"),
                       ("11: amy\n12: amy\n", "named for two domains"), ("- amy\n", "maps domain ids"),
                       ("11: [amy\n", "team.yaml")):
        team.write_text(text)
        with pytest.raises(ProfileError, match=said):
            load_team(team)
    assert Ros2Setup(domains=(0,), team={11: "amy"}).listened() == (0, 11)


def test_the_shipped_profiles_name_real_types_and_panels() -> None:
    assert load_profile("pitchside").topics == {}
    bitbots = load_profile("bitbots")
    assert set(bitbots.topics) == {"robot_state", "gamestate", "balls_relative", "pose_with_covariance",
                                   "team_data", "strategy", "head_mode", "speak"}
    for mapped in bitbots.topics.values():  # each type is in the team's folder: hashed, so fully defined
        assert codec.type_hash(mapped.ros_type).startswith("RIHS01_"), mapped


def test_a_profile_that_does_not_fit_says_where() -> None:
    for data, said in (({"topics": {}}, "with a name"),
                       ({"name": "x", "topics": {"a": {"type": "p/msg/T", "panel": "nope"}}}, "topics.a: panel"),
                       ({"name": "x", "topics": {"a": {"type": "p/msg/T"}}}, "needs type and panel"),
                       ({"name": "x", "topics": {"/a": {"type": "p/msg/T", "panel": "gamestate"}}}, "relative"),
                       ({"name": "x", "by_type": {"std_msgs/msg/Float32": "gamestate"}}, "needs a mapping"),
                       ({"name": "x", "topics": {"a": {"type": "p/msg/T", "panel": "gamestate",
                                                       "fields": {"game_state": {"guess": 1}}}}}, "fields.game_state")):
        with pytest.raises(ProfileError, match=said):
            profile_from(data)


def test_routes_robots_are_namespaces_or_domains() -> None:
    setup = Ros2Setup(domains=(0,), team={11: "amy"}, profile=load_profile("bitbots"))
    ours = route_of(key(0, "/robot1/joint_states", "sensor_msgs/msg/JointState"), setup)
    assert (ours.robot, ours.topic, ours.table) == ("robot1", "joint_states", True)
    theirs = route_of(key(11, "/joint_states", "sensor_msgs/msg/JointState"), setup)
    assert (theirs.robot, theirs.topic, theirs.table) == ("amy", "joint_states", False)
    state = route_of(key(11, "/robot_state", "bitbots_msgs/msg/RobotControlState"), setup)
    assert (state.topic, state.typename) == ("robot_state", "humanoid_league_msgs/msg/RobotControlState")
    camera = route_of(key(11, "/camera/image_proc", "sensor_msgs/msg/Image"), setup)  # by type, made a JPEG
    assert (camera.topic, camera.typename) == ("camera/image/compressed", "sensor_msgs/msg/CompressedImage")
    own = route_of(key(11, "/time_to_ball", "std_msgs/msg/Float32"), setup)  # no panel: its own name and type
    assert (own.robot, own.topic, own.typename) == ("amy", "time_to_ball", "std_msgs/msg/Float32")
    rosout = route_of(key(0, "/rosout", "rcl_interfaces/msg/Log"), setup)
    assert (rosout.robot, rosout.topic) == ("", "rosout")  # the robot comes from each record's node name

    refused = {
        key(0, "/joint_states", "sensor_msgs/msg/JointState"): Refusal.NO_ROBOT,
        key(0, "/robot1/animation/_action/status", "std_msgs/msg/Bool"): Refusal.HIDDEN,
        key(11, "/secret", "bitbots_msgs/msg/Secret", "RIHS01_" + "0" * 64): Refusal.DEFINITION_MISSING,
        key(11, "/speed", "std_msgs/msg/Float32", codec.type_hash("std_msgs/msg/Float64")): Refusal.HASH_MISMATCH,
        key(0, "/a_robot_id_too_long/joint_states", "sensor_msgs/msg/JointState"): Refusal.BAD_NAME,
        "0/robot1/joint_states": Refusal.BAD_KEY,
    }
    for bad, reason in refused.items():
        with pytest.raises(RouteRefused) as caught:
            route_of(bad, setup)
        assert caught.value.reason is reason, bad


def test_the_global_rosout_names_its_robot_by_the_logger() -> None:
    log = codec.make("rcl_interfaces/msg/Log", name="robot1.hcm")
    assert robot_of_log(log) == "robot1"
    assert robot_of_log(codec.make("rcl_interfaces/msg/Log", name="hcm")) == ""  # a root node: no robot
    assert robot_of_log(codec.make("rcl_interfaces/msg/Log", name="<b>.hcm")) == ""


def test_translations_onto_pitchsides_panels() -> None:
    bitbots = load_profile("bitbots").topics
    pose = codec.make("geometry_msgs/msg/PoseWithCovarianceStamped")
    half_turn = math.pi / 2
    pose.pose.pose.position.x, pose.pose.pose.position.y = 1.5, -2.0
    pose.pose.pose.orientation.z, pose.pose.pose.orientation.w = math.sin(half_turn / 2), math.cos(half_turn / 2)
    position = translate(bitbots["pose_with_covariance"], pose)
    assert (position.pose.x, position.pose.y) == (1.5, -2.0)
    assert position.pose.theta == pytest.approx(half_turn) and position.confidence == 1.0

    strategy = codec.make("bitbots_msgs/msg/Strategy", role=6, action=8, offensive_side=3)  # GOALIE, PASSIVE, RIGHT
    ours = translate(bitbots["strategy"], strategy)
    assert (ours.role, ours.action, ours.offensive_side) == (5, 0, 2)  # their PASSIVE has no match: left at zero

    no_ball = translate(bitbots["balls_relative"], codec.make("soccer_vision_3d_msgs/msg/BallArray"))
    assert no_ball.confidence == 0.0
    ball = codec.make("soccer_vision_3d_msgs/msg/Ball")
    ball.center.x, ball.confidence.confidence = 0.8, 0.9
    seen = translate(bitbots["balls_relative"], codec.make("soccer_vision_3d_msgs/msg/BallArray", balls=[ball]))
    assert seen.ball_relative.x == pytest.approx(0.8) and seen.confidence == pytest.approx(0.9)

    mate = codec.make("bitbots_msgs/msg/TeamData", robot_id=3, state=1)
    mate.strategy.role = 4  # SUPPORTER
    team = translate(bitbots["team_data"], mate)
    assert list(team.robot_ids) == [3] and list(team.state) == [1] and list(team.role) == [3]
    codec.encode(team)  # a valid message of pitchside's type, as the hub and recordings need


def test_a_raw_image_becomes_the_camera_panels_jpeg() -> None:
    width, height = 8, 4
    bgr = np.zeros((height, width + 1, 3), dtype=np.uint8)  # a row padded by one pixel (step > width * 3)
    bgr[:, :width, 2] = 250  # red, in BGR order
    image = codec.make("sensor_msgs/msg/Image", height=height, width=width, encoding="bgr8",
                       step=(width + 1) * 3, data=bgr.reshape(-1))
    compressed = jpeg_of(image)
    assert compressed.format == "jpeg"
    decoded = np.asarray(Image.open(io.BytesIO(bytes(compressed.data))))
    assert decoded.shape == (height, width, 3) and decoded[..., 0].min() > 200 and decoded[..., 2].max() < 60
    with pytest.raises(ImageEncodingError, match="16UC1"):
        jpeg_of(codec.make("sensor_msgs/msg/Image", height=1, width=1, encoding="16UC1", step=2, data=[0, 0]))
    with pytest.raises(ImageEncodingError, match="needs"):
        jpeg_of(codec.make("sensor_msgs/msg/Image", height=2, width=2, encoding="mono8", step=2, data=[0]))


def test_the_demo_hands_its_ros2_flags_to_its_dashboard(tmp_path: Path) -> None:
    import argparse

    from pitchside.demo import demo_processes
    from pitchside.local_run import DashboardPlan
    from server.__main__ import arguments, config_from
    from server.profiles.flags import add_ros2_arguments, ros2_flags

    team = tmp_path / "team.yaml"
    team.write_text("11: amy\n")
    parser = argparse.ArgumentParser()
    add_ros2_arguments(parser)
    given = parser.parse_args(["--ros-domains", "0,11-12", "--ros-team", str(team), "--ros-profile", "bitbots",
                               "--ros-interfaces", str(INTERFACES)])
    flags = ros2_flags(given)
    processes = demo_processes(robots=1, endpoint="tcp/127.0.0.1:7447", http_port=8080,
                               dashboard=DashboardPlan(5800, 5801, 5802, 5803), model="minibot", match=False,
                               gc_ports=[3838], gc_return_port=3939, server_flags=flags)
    (server,) = [p for p in processes if p.name == "server"]
    at = server.argv.index(flags[0])
    assert server.argv[at:at + len(flags)] == flags
    config = config_from(arguments().parse_args(server.argv[server.argv.index("server") + 1:]))
    assert config.ros2.listened() == (0, 11, 12) and config.ros2.team == {11: "amy"}
    assert config.ros2.profile.name == "bitbots" and config.ros2.interfaces == INTERFACES.resolve()
    with pytest.raises(SystemExit, match="not a folder"):
        config_from(arguments().parse_args(["--ros-interfaces", str(tmp_path / "absent")]))


def test_the_flags_name_the_shipped_profiles() -> None:
    """flags.py (read by --help, so without the profiles' code) names the same shipped profiles as profile.py."""
    from server.profiles import flags, profile

    assert flags.SHIPPED_NAMES == profile.SHIPPED
    assert all((Path(profile.__file__).parent / f"{name}.yaml").is_file() for name in profile.SHIPPED)
