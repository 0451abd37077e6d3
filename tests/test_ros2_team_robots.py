"""A Bit-Bots robot on the dashboard: its own ROS_DOMAIN_ID (11), root topics, its team's own types, through a real
Zenoh router, with the dashboard in this process (its app, live source and websocket as a browser reaches them).

The robot is a ROS 2 peer written here from rmw_zenoh's protocol description (docs/design.md of 0.2.x: data keys,
liveliness tokens, the attachment) with raw Zenoh calls, struct and rosbags' own CDR and RIHS01 code, never
pitchside's wire.ros2 or schemas, so the dashboard can only show it if it reads the documented wire.
"""

from __future__ import annotations

import contextlib
import itertools
import struct
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import zenoh
import zenoh.ext
from fastapi.testclient import TestClient
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from server.__main__ import arguments, config_from
from server.app import create_app
from server.robot3d import load_urdf, own_description
from tests.support import REPO, TESTDATA
from tests.waiting import wait_for
from wire.bus import BusConfig, open_session

INTERFACES = TESTDATA / "ros2_interfaces"
DOMAIN = 11
BITBOTS_TYPES = {"bitbots_msgs/msg/RobotControlState": "bitbots_msgs/msg/RobotControlState.msg",
                 "game_controller_hsl_interfaces/msg/GameState": "game_controller_hsl_interfaces/msg/GameState.msg"}
MISSING_TYPE = "bitbots_msgs/msg/Secret"  # in no folder the dashboard has
QOS = "::,10:,:,:,,"  # design.md: reliable, volatile, keep last 10 (the defaults left empty)


def robot_typestore() -> Any:
    """The robot's own types as its ROS 2 build has them: Jazzy plus the Bit-Bots packages' .msg files."""
    store = get_typestore(Stores.ROS2_JAZZY)
    for name, file in BITBOTS_TYPES.items():
        store.register(get_types_from_msg((INTERFACES / file).read_text(), name))
    return store


class BitbotsRobot:
    """amy as rmw_zenoh shows her: node tokens, publisher tokens and samples with the attachment, root namespace."""

    def __init__(self, session: zenoh.Session) -> None:
        self.session = session
        self.store = robot_typestore()
        self.zid = str(session.zid())
        self.tokens: list[Any] = []
        self.sequence = itertools.count(1)
        self.entity_ids = itertools.count(1)
        self.keys: dict[str, str] = {}

    def node(self, name: str) -> None:
        node_id = next(self.entity_ids)
        self.tokens.append(self.session.liveliness().declare_token(
            f"@ros2_lv/{DOMAIN}/{self.zid}/{node_id}/{node_id}/NN/%/%/{name}"))
        self._node_id = node_id

    def publisher(self, node: str, topic: str, ros_type: str, type_hash: str) -> None:
        """design.md's publisher token, and the data key its samples go to."""
        package, kind, name = ros_type.split("/")
        dds = f"{package}::{kind}::dds_::{name}_"
        self.tokens.append(self.session.liveliness().declare_token(
            f"@ros2_lv/{DOMAIN}/{self.zid}/{self._node_id}/{next(self.entity_ids)}/MP/%/%/{node}/"
            f"%{topic.replace('/', '%')}/{dds}/{type_hash}/{QOS}"))
        self.keys[topic] = f"{DOMAIN}/{topic}/{dds}/{type_hash}"

    def hash(self, ros_type: str) -> str:
        return str(self.store.hash_rihs01(ros_type))

    def cdr(self, ros_type: str, **fields: Any) -> bytes:
        return bytes(self.store.serialize_cdr(self.store.types[ros_type](**fields), ros_type))

    def put(self, topic: str, payload: bytes) -> None:
        """design.md's attachment: int64 sequence number, int64 source time (ns), GID as a length-prefixed 16 bytes."""
        gid = bytes(range(16))
        attachment = struct.pack("<qqB", next(self.sequence), time.time_ns(), len(gid)) + gid
        self.session.put(self.keys[topic], payload, attachment=attachment)

    def close(self) -> None:
        for token in self.tokens:
            token.undeclare()


def stamp(store: Any) -> Any:
    return store.types["builtin_interfaces/msg/Time"](sec=int(time.time()), nanosec=0)


def header(store: Any) -> Any:
    return store.types["std_msgs/msg/Header"](stamp=stamp(store), frame_id="base_link")


@pytest.fixture
def amy(bus: BusConfig) -> Iterator[BitbotsRobot]:
    session = open_session(bus)
    robot = BitbotsRobot(session)
    robot.node("hcm")
    robot.publisher("hcm", "robot_state", "bitbots_msgs/msg/RobotControlState",
                    robot.hash("bitbots_msgs/msg/RobotControlState"))
    robot.publisher("hcm", "diagnostics", "diagnostic_msgs/msg/DiagnosticArray",
                    robot.hash("diagnostic_msgs/msg/DiagnosticArray"))
    robot.publisher("hcm", "rosout", "rcl_interfaces/msg/Log", robot.hash("rcl_interfaces/msg/Log"))
    robot.node("game_controller")
    robot.publisher("game_controller", "gamestate", "game_controller_hsl_interfaces/msg/GameState",
                    robot.hash("game_controller_hsl_interfaces/msg/GameState"))
    robot.node("ros_control")
    robot.publisher("ros_control", "joint_states", "sensor_msgs/msg/JointState",
                    robot.hash("sensor_msgs/msg/JointState"))
    robot.publisher("ros_control", "system_secret", MISSING_TYPE, "RIHS01_" + "ab" * 32)
    # a float with another type's hash (a stale build): refused, never decoded as a Float32
    robot.publisher("ros_control", "time_to_ball", "std_msgs/msg/Float32", robot.hash("std_msgs/msg/Float64"))
    yield robot
    robot.close()
    session.close()


@contextlib.contextmanager
def serving(bus: BusConfig, tmp_path: Path, profile: str = "bitbots") -> Iterator[TestClient]:
    """The dashboard as `pitchside serve --ros-domains 0,11 --ros-team team.yaml --ros-profile bitbots
    --ros-interfaces tests/data/ros2_interfaces` makes it (the guide's command), in this process."""
    team = tmp_path / "team.yaml"
    team.write_text("11: amy\n12: rory\n")
    args = arguments().parse_args(["--connect", *bus.connect, "--no-telemetry", "--ros-domains", "0,11",
                                   "--ros-team", str(team), "--ros-profile", profile,
                                   "--ros-interfaces", str(INTERFACES)])
    config = config_from(args)
    assert config.ros2.listened() == (0, 11, 12)  # the team file's domains are listened to as well
    config.recordings_dir, config.auto_record_matches = tmp_path, False
    with TestClient(create_app(config), base_url="http://127.0.0.1",
                    headers={"Authorization": f"Bearer {config.token}"}) as client:
        yield client


@pytest.fixture
def dashboard(bus: BusConfig, tmp_path: Path) -> Iterator[TestClient]:
    with serving(bus, tmp_path) as client:
        yield client


def live_status(http: TestClient) -> dict[str, Any]:
    return next(s for s in http.get("/api/sources").json() if s["name"] == "live")


def test_a_bitbots_robot_in_its_own_domain_is_shown_as_amy(amy: BitbotsRobot, dashboard: TestClient) -> None:
    # found from its liveliness tokens before it sent anything
    def ros2_amy() -> dict[str, Any] | None:
        found = dashboard.get("/api/ros2/robots").json()["robots"]
        return next((r for r in found if r["robot"] == "amy" and len(r["topics"]) == 7), None)

    robot = wait_for(ros2_amy, 30.0, what="amy from her tokens")
    assert robot["domain"] == DOMAIN
    assert robot["nodes"] == ["/game_controller", "/hcm", "/ros_control"]
    topics = {t["name"]: (t["status"], t["panel"]) for t in robot["topics"]}
    assert topics["/robot_state"] == ("shown", "robot_state")
    assert topics["/gamestate"] == ("shown", "gamestate")
    assert topics["/joint_states"] == ("shown", "joint_states")
    assert topics["/system_secret"] == ("definition missing", None)
    assert topics["/time_to_ball"][0].startswith("type hash does not match")
    assert dashboard.get("/api/robots").json() == []  # no data yet: the hub has no robot

    store = amy.store
    control_state = store.types["bitbots_msgs/msg/RobotControlState"]
    game_state = store.types["game_controller_hsl_interfaces/msg/GameState"]
    state = amy.cdr("bitbots_msgs/msg/RobotControlState", state=control_state.FALLEN)
    game = amy.cdr("game_controller_hsl_interfaces/msg/GameState", header=header(store), players_per_team=4,
                   competition_type=0, game_phase=0, main_state=game_state.STATE_PLAYING, set_play=0,
                   first_half=True, stopped=False, kicking_team=8, own_score=2, rival_score=1, seconds_remaining=321,
                   secondary_time=0, own_player_color=game_state.TEAM_RED, own_goalie_color=0, rival_player_color=0,
                   rival_goalie_color=0, penalty_shot=0, single_shots=0, message_budget=1200,
                   team_mates_with_penalty=np.array([False, True]), team_mates_with_yellow_card=np.array([], bool),
                   team_mates_with_red_card=np.array([], bool), penalty=0, penalized=False, penalized_in_place=False,
                   seconds_till_unpenalized=0, cautions=0, has_yellow_card=False, has_red_card=False)
    joints = amy.cdr("sensor_msgs/msg/JointState", header=header(store), name=["HeadPan", "HeadTilt"],
                     position=np.array([0.25, -0.5]), velocity=np.zeros(0), effort=np.zeros(0))
    log = amy.cdr("rcl_interfaces/msg/Log", stamp=stamp(store), level=20, name="hcm", msg="fell forward", file="",
                  function="", line=0)

    def published() -> bool:
        for topic, payload in (("robot_state", state), ("gamestate", game), ("joint_states", joints),
                               ("rosout", log)):
            amy.put(topic, payload)
        robots = {r["robot"]: r for r in dashboard.get("/api/robots").json()}
        return "amy" in robots and {"robot_state", "gamestate", "joint_states", "rosout"} <= set(
            robots["amy"]["streams"])

    wait_for(published, 30.0, 0.05, "amy's messages in the dashboard")
    robots = {r["robot"]: r for r in dashboard.get("/api/robots").json()}
    assert set(robots) == {"amy"}
    assert robots["amy"]["streams"]["robot_state"]["msgtype"] == "humanoid_league_msgs/msg/RobotControlState"
    fields = dashboard.get("/api/fields/amy/joint_states").json()["fields"]  # what plots and field choosers offer
    assert {f["name"] for f in fields} >= {"position/HeadPan", "position/HeadTilt"}

    with dashboard.websocket_connect("ws://127.0.0.1/ws") as ws:
        assert ws.receive_json()["type"] == "hello"
        for topic in ("robot_state", "gamestate", "joint_states", "rosout"):
            ws.send_json({"op": "subscribe", "robot": "amy", "topic": topic})
        frames: dict[str, dict[str, Any]] = {}
        while len(frames) < 4:  # the newest of each stream comes at once on subscribing
            frame = ws.receive_json()
            for one in frame["frames"] if frame["type"] == "batch" else [frame]:
                if one["type"] == "msg" and one["robot"] == "amy":
                    frames[one["topic"]] = one
    assert frames["robot_state"]["data"]["state"] == 2  # FALLEN, the HCM panel's number for it
    game_frame = frames["gamestate"]["data"]
    assert (game_frame["game_state"], game_frame["own_score"], game_frame["seconds_remaining"]) == (3, 2, 321)
    assert game_frame["team_color"] == 1 and game_frame["version"] == 20
    assert game_frame["team_mates_with_penalty"] == [0, 1]  # their bool[] as pitchside's uint8[]
    assert frames["joint_states"]["data"]["name"] == ["HeadPan", "HeadTilt"]
    assert frames["joint_states"]["data"]["position"] == [0.25, -0.5]
    assert frames["rosout"]["data"]["msg"] == "fell forward"


def test_bad_samples_from_a_ros2_robot_are_counted_and_nothing_crashes(amy: BitbotsRobot,
                                                                      dashboard: TestClient) -> None:
    secret = b"\x00\x01\x00\x00" + b"\x07" * 8
    float32 = b"\x00\x01\x00\x00" + struct.pack("<f", 1.5)
    not_diagnostics = b"\x00\x01\x00\x00" + b"\xff" * 7  # a DiagnosticArray's header says 4 GB of frame id

    def counted() -> dict[str, Any] | None:
        amy.put("system_secret", secret)
        amy.put("time_to_ball", float32)
        amy.put("diagnostics", not_diagnostics)
        status = live_status(dashboard)
        ok = (status["refused"].get("DEFINITION_MISSING", 0) >= 2 and status["refused"].get("HASH_MISMATCH", 0) >= 2
              and status["undecodable"] >= 2)
        return status if ok else None

    status = wait_for(counted, 30.0, 0.05, lambda: f"the bad samples counted: {live_status(dashboard)}")
    assert status["definitions_missing"] == [MISSING_TYPE]
    assert status["running"] and status["bad_names"] == 0
    assert dashboard.get("/api/robots").json() == []  # none of it reached the hub

    state = amy.cdr("bitbots_msgs/msg/RobotControlState", state=10)  # the robot's good data still passes
    wait_for(lambda: amy.put("robot_state", state) or any(r["robot"] == "amy"
                                                          for r in dashboard.get("/api/robots").json()),
             30.0, 0.05, "amy's good data after the bad")


def test_a_latched_robot_description_reaches_a_dashboard_started_later(bus: BusConfig, tmp_path: Path) -> None:
    """rmw_zenoh keeps a transient local topic in a zenoh-ext cache; the 3D view takes the robot's own URDF from it,
    its meshes through the profile's package:// map."""
    wolfgang = TESTDATA / "robots" / "wolfgang"
    profile = tmp_path / "bitbots_lab.yaml"  # the shipped profile, plus where this laptop keeps the meshes
    profile.write_text((REPO / "server" / "profiles" / "bitbots.yaml").read_text()
                       + f"packages:\n  wolfgang_description: {wolfgang}\n")
    session = open_session(bus)
    robot = BitbotsRobot(session)
    robot.node("robot_state_publisher")
    string_hash = robot.hash("std_msgs/msg/String")
    robot.tokens.append(session.liveliness().declare_token(
        f"@ros2_lv/{DOMAIN}/{robot.zid}/1/2/MP/%/%/robot_state_publisher/%robot_description/"
        f"std_msgs::msg::dds_::String_/{string_hash}/:1:,1:,:,:,,"))  # transient local, keep last 1
    urdf = (wolfgang / "urdf" / "robot.urdf").read_text()
    latched = zenoh.ext.declare_advanced_publisher(
        session, f"{DOMAIN}/robot_description/std_msgs::msg::dds_::String_/{string_hash}",
        cache=zenoh.ext.CacheConfig(max_samples=1), publisher_detection=True)
    gid = bytes(range(16))
    latched.put(robot.cdr("std_msgs/msg/String", data=urdf),
                attachment=struct.pack("<qqB", 1, time.time_ns(), len(gid)) + gid)
    try:
        with serving(bus, tmp_path, str(profile)) as dashboard:  # started after the robot said it, once
            def described() -> bool:
                robots = {r["robot"]: r for r in dashboard.get("/api/robots").json()}
                return "robot_description" in robots.get("amy", {}).get("streams", {})

            wait_for(described, 30.0, 0.05, "amy's latched robot_description")
            state = dashboard.app.state.pitchside  # type: ignore[attr-defined]
            own = own_description(state.hub, state.config, "amy", tmp_path)
            assert own is not None and own.urdf.read_text() == urdf
            assert own.packages == {"wolfgang_description": wolfgang.resolve()}
            model = load_urdf(own)  # every package:// mesh found through the profile's map
            assert "HeadPan" in model.actuated_joint_names and len(model.scene.geometry) > 20
    finally:
        latched.undeclare()
        robot.close()
        session.close()
