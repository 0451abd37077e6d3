"""Test helper: a real node that publishes what the dashboard shows (state, joints, images, detections...)."""

from __future__ import annotations

import io
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

import schemas
from robot_nodes.runtime import Node, header, param, run

JOINTS = [f"joint{i}" for i in range(20)]
HL = "humanoid_league_msgs/msg/"


def jpeg(width: int = 320, height: int = 240, noise: bool = False) -> bytes:
    from PIL import Image

    if noise:
        pixels = np.random.default_rng(0).integers(0, 255, (height, width, 3), dtype=np.uint8)
    else:
        pixels = np.zeros((height, width, 3), dtype=np.uint8)
        pixels[:, :, 1] = 110  # green field
        pixels[height // 2:height // 2 + 4, :, :] = 255  # a white line
    out = io.BytesIO()
    Image.fromarray(pixels).save(out, format="JPEG", quality=90)
    return out.getvalue()


def point(x: float, y: float, z: float = 0.0) -> Any:
    return schemas.make("geometry_msgs/msg/Point", x=x, y=y, z=z)


@dataclass
class TestStandParams:
    rate_hz: float = param(50.0, range=(1.0, 1000.0), doc="joint_states and robot_state rate")
    image_hz: float = param(0.0, range=(0.0, 60.0), doc="camera image rate (0: none)")
    noisy_image: bool = param(False, doc="incompressible images (big frames)")
    joints: str = param("", doc="comma-separated joint names (default joint0..joint19)")


class TestStand(Node):
    """Publishes robot_state and joint_states at rate_hz with a sequence number in the first joint position."""

    __test__ = False  # not a pytest class
    name = "teststand"
    Params = TestStandParams

    def setup(self) -> None:
        self.seq = 0
        self.hcm_state = 10  # WALKING
        self.joint_names = [j.strip() for j in self.params.joints.split(",") if j.strip()] or JOINTS
        self.state_pub = self.publisher("robot_state")
        self.joints_pub = self.publisher("joint_states")
        self.image_pub = self.publisher("camera/image/compressed")
        self.timer(self.tick, rate_hz=self.params.rate_hz)
        if self.params.image_hz > 0:
            self.image = jpeg(640, 480, noise=self.params.noisy_image)
            self.timer(self.publish_image, rate_hz=self.params.image_hz)

    def tick(self) -> None:
        self.seq += 1
        self.state_pub.publish(schemas.make(HL + "RobotControlState", state=self.hcm_state))
        n = len(self.joint_names)
        positions = [float(self.seq)] + [0.3 * math.sin(self.seq * 0.05 + i) for i in range(n - 1)]
        self.joints_pub.publish(schemas.make("sensor_msgs/msg/JointState", header=header("base_link"),
                                             name=self.joint_names, position=positions))

    def publish_image(self) -> None:
        self.image_pub.publish(schemas.make("sensor_msgs/msg/CompressedImage", header=header("camera"),
                                            format="jpeg", data=np.frombuffer(self.image, dtype=np.uint8)))


HCM_STATES = ["STARTUP", "CONTROLLABLE", "WALKING", "FALLING", "FALLEN", "GETTING_UP", "PENALTY"]
HCM_TRANSITIONS = [("STARTUP", "CONTROLLABLE", "motors on"), ("CONTROLLABLE", "WALKING", "walking_active"),
                   ("WALKING", "CONTROLLABLE", "stopped"), ("WALKING", "FALLING", "imu tilt"),
                   ("CONTROLLABLE", "FALLING", "imu tilt"), ("FALLING", "FALLEN", "lying"),
                   ("FALLEN", "GETTING_UP", "stand up"), ("GETTING_UP", "CONTROLLABLE", "done"),
                   ("CONTROLLABLE", "PENALTY", "penalized"), ("PENALTY", "CONTROLLABLE", "unpenalized")]


@dataclass
class SceneStandParams:
    x: float = param(-2.0, range=(-6.0, 6.0), doc="own x on the field (m)")
    y: float = param(1.0, range=(-4.0, 4.0), doc="own y on the field (m)")
    penalized: bool = param(False, doc="the GameController says penalized")


class SceneStand(Node):
    """Publishes one of everything the dashboard panels draw, at 5 Hz, with known values."""

    __test__ = False
    name = "scenestand"
    Params = SceneStandParams

    def setup(self) -> None:
        self.pubs = {t: self.publisher(t) for t in (
            "robot_state", "gamestate", "position", "ball_relative", "obstacles_relative", "goal_relative",
            "hcm_graph", "camera/image/compressed", "ball_in_image", "goal_in_image", "servo_data")}
        self.image = np.frombuffer(jpeg(320, 240), dtype=np.uint8)
        self.timer(self.tick, rate_hz=5.0)

    def tick(self) -> None:
        p = self.pubs
        p["robot_state"].publish(schemas.make(HL + "RobotControlState", state=10))
        p["gamestate"].publish(schemas.make(HL + "GameState", header=header(), game_state=3, own_score=2,
                                            rival_score=1, seconds_remaining=437, first_half=True,
                                            penalized=self.params.penalized))
        pose = schemas.make("geometry_msgs/msg/Pose2D", x=self.params.x, y=self.params.y, theta=0.5)
        p["position"].publish(schemas.make(HL + "Position2D", header=header("map"), pose=pose, confidence=0.8))
        p["ball_relative"].publish(schemas.make(HL + "BallRelative", header=header(), ball_relative=point(1.0, 0.2),
                                                confidence=0.9))
        obstacle = schemas.make(HL + "ObstacleRelative", color=2, position=point(1.5, -0.5), width=0.3, confidence=0.7)
        p["obstacles_relative"].publish(schemas.make(HL + "ObstaclesRelative", header=header(), obstacles=[obstacle]))
        p["goal_relative"].publish(schemas.make(HL + "GoalRelative", header=header(), left_post=point(3.0, 1.3),
                                                right_post=point(3.0, -1.3), center_direction=point(3.0, 0.0),
                                                confidence=0.6))
        stamps = [schemas.make("builtin_interfaces/msg/Time", sec=1_700_000_000 + i) for i in range(3)]
        p["hcm_graph"].publish(schemas.make(
            "pitchside_msgs/msg/StateMachineGraph", header=header(), name="hcm", states=HCM_STATES,
            transition_from=[t[0] for t in HCM_TRANSITIONS], transition_to=[t[1] for t in HCM_TRANSITIONS],
            transition_condition=[t[2] for t in HCM_TRANSITIONS], current="WALKING",
            history_states=["STARTUP", "CONTROLLABLE", "WALKING"], history_stamps=stamps))
        p["camera/image/compressed"].publish(schemas.make("sensor_msgs/msg/CompressedImage", header=header("camera"),
                                                          format="jpeg", data=self.image))
        ball = schemas.make(HL + "BallInImage", center=point(200.0, 150.0), diameter=30.0, confidence=0.85)
        p["ball_in_image"].publish(schemas.make(HL + "BallsInImage", header=header(), candidates=[ball]))
        post = schemas.make(HL + "PostInImage", foot_point=point(60.0, 200.0), top_point=point(60.0, 60.0),
                            width=8.0, confidence=0.75)
        p["goal_in_image"].publish(schemas.make(HL + "GoalPartsInImage", header=header(), posts=[post]))
        temps = [schemas.make("sensor_msgs/msg/Temperature", header=header(f"joint{i}"), temperature=40.0 + i)
                 for i in range(3)]
        p["servo_data"].publish(schemas.make(HL + "AdditionalServoData", header=header(), temperature=temps,
                                             voltage=[12.1, 12.3]))


BEHAVIOUR_STATES = ["INITIAL", "WALK_IN", "STAND", "SEARCH_BALL", "GO_TO_BALL", "KICK", "PENALIZED"]
BEHAVIOUR_TRANSITIONS = [
    ("INITIAL", "WALK_IN", "READY"), ("WALK_IN", "STAND", "SET"), ("STAND", "SEARCH_BALL", "PLAYING"),
    ("SEARCH_BALL", "GO_TO_BALL", "ball seen"), ("GO_TO_BALL", "KICK", "at the ball"),
    ("KICK", "SEARCH_BALL", "kicked"), ("GO_TO_BALL", "SEARCH_BALL", "ball lost"),
    ("SEARCH_BALL", "PENALIZED", "penalized"), ("PENALIZED", "SEARCH_BALL", "unpenalized")]


@dataclass
class MatchStandParams:
    team_color: int = param(0, range=(0, 9), doc="the GameController's colour of the robot's team")
    player: int = param(1, range=(1, 11), doc="player number")
    x: float = param(-2.0, range=(-6.0, 6.0), doc="own x on the field (m)")
    y: float = param(0.0, range=(-4.0, 4.0), doc="own y on the field (m)")
    theta: float = param(0.0, range=(-4.0, 4.0), doc="own heading (rad)")
    role: int = param(3, range=(0, 5), doc="Strategy role")
    own_score: int = param(0, range=(0, 99), doc="")
    rival_score: int = param(0, range=(0, 99), doc="")
    kick_off: bool = param(False, doc="the team has the kick-off")
    penalty_s: int = param(0, range=(0, 255), doc="> 0: penalised, this many seconds left")
    hcm_state: int = param(10, range=(0, 20), doc="RobotControlState")
    ball: str = param("", doc="the ball relative to the robot as 'x,y' (empty: not seen)")
    mates: str = param("", doc="teammates heard as 'number:age_s:loss_pct,...'")
    behavior: bool = param(False, doc="publish a behaviour state graph")
    gc_version: int = param(0, range=(0, 255), doc="GameState.version (20: an HSL GameController with a budget)")
    message_budget: int = param(65535, range=(0, 65535), doc="the team's messages left (GameState, team_comm)")
    send_rate_hz: float = param(0.0, range=(0.0, 100.0), doc="team_comm: this robot's team messages per second")
    budget_rate_hz: float = param(-1.0, range=(-1.0, 100.0), doc="team_comm: the rate its budget allows (-1: none)")


class MatchStand(Node):
    """A robot of a team in a match, at 5 Hz: its game state (team colour, score, penalty), role, pose, seen ball,
    what it hears of its teammates and, if asked, its behaviour's state graph."""

    __test__ = False
    name = "matchstand"
    Params = MatchStandParams

    def setup(self) -> None:
        self.pubs = {t: self.publisher(t) for t in (
            "robot_state", "gamestate", "position", "ball_relative", "strategy", "team_comm", "servo_data",
            "behavior_graph")}
        self.timer(self.tick, rate_hz=5.0)

    def tick(self) -> None:
        p, q = self.pubs, self.params
        p["robot_state"].publish(schemas.make(HL + "RobotControlState", state=q.hcm_state))
        p["gamestate"].publish(schemas.make(
            HL + "GameState", header=header(), game_state=3, first_half=True, own_score=q.own_score,
            rival_score=q.rival_score, seconds_remaining=312, has_kick_off=q.kick_off, team_color=q.team_color,
            penalized=q.penalty_s > 0, seconds_till_unpenalized=q.penalty_s, allowed_to_move=q.penalty_s == 0,
            version=q.gc_version, message_budget=q.message_budget))
        pose = schemas.make("geometry_msgs/msg/Pose2D", x=q.x, y=q.y, theta=q.theta)
        p["position"].publish(schemas.make(HL + "Position2D", header=header("map"), pose=pose, confidence=0.9))
        if q.ball:
            bx, by = (float(v) for v in q.ball.split(","))
            p["ball_relative"].publish(schemas.make(HL + "BallRelative", header=header(),
                                                    ball_relative=point(bx, by), confidence=0.9))
        p["strategy"].publish(schemas.make(HL + "Strategy", role=q.role, action=2))
        mates = [tuple(float(v) for v in m.split(":")) for m in q.mates.split(",") if m]
        p["team_comm"].publish(schemas.make(
            "pitchside_msgs/msg/TeamCommStatus", header=header(), team_id=q.team_color + 1, player_id=q.player,
            mate_ids=[int(m[0]) for m in mates], age=[m[1] for m in mates], loss_pct=[m[2] for m in mates],
            received=[round(20 * (1 - m[2] / 100)) for m in mates], window_s=10.0, expected_rate_hz=2.0,
            memory_s=30.0, send_rate_hz=q.send_rate_hz, message_budget=q.message_budget,
            budget_rate_hz=q.budget_rate_hz))
        temps = [schemas.make("sensor_msgs/msg/Temperature", header=header("RKnee"), temperature=55.0 + q.player)]
        p["servo_data"].publish(schemas.make(HL + "AdditionalServoData", header=header(), temperature=temps,
                                             voltage=[14.8]))
        if q.behavior:
            p["behavior_graph"].publish(schemas.make(
                "pitchside_msgs/msg/StateMachineGraph", header=header(), name="behavior", states=BEHAVIOUR_STATES,
                transition_from=[t[0] for t in BEHAVIOUR_TRANSITIONS],
                transition_to=[t[1] for t in BEHAVIOUR_TRANSITIONS],
                transition_condition=[t[2] for t in BEHAVIOUR_TRANSITIONS], current="GO_TO_BALL",
                history_states=["STAND", "SEARCH_BALL", "GO_TO_BALL"]))


if __name__ == "__main__":  # a stand-in robot on a test machine: python -m tests.teststand --robot-id ...
    run(TestStand)
