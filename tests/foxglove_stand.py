"""Test helper: a real node standing in for a robot in a known pose, for the Foxglove 3D scene and parameters.

It publishes the minibot's joint_states (each joint at its own known angle), a level IMU, its position on the field
(from its parameters), the ball and an obstacle where it sees them, and a simulation's ground truth (its torso and the
ball); its parameters have a range and a start-up one.
"""

from __future__ import annotations

from dataclasses import dataclass

import schemas
from robot_nodes.runtime import Node, header, param
from server.transforms import load_kinematics

HL = "humanoid_league_msgs/msg/"
BALL = (1.2, -0.3)
OBSTACLE = (2.0, 0.5)
TRUE_TORSO = (1.1, -1.9, 0.42)  # where the simulation says the torso is (the ground truth)
TRUE_BALL = (2.3, -2.1, 0.05)


def known_pose() -> dict[str, float]:
    """Every movable minibot joint at an angle of its own (within every joint's limits)."""
    import robots

    names = load_kinematics(robots.urdf()).joint_names
    return {name: 0.05 * (i + 1) * (-1) ** i for i, name in enumerate(names)}


@dataclass
class PoseStandParams:
    x: float = param(1.0, range=(-6.0, 6.0), doc="own x on the field (m)")
    y: float = param(-2.0, range=(-4.5, 4.5), doc="own y on the field (m)")
    theta: float = param(0.5, range=(-3.2, 3.2), doc="own heading (rad)")
    model: str = param("minibot", startup=True, doc="the robot model, read once at start")
    rate_hz: float = param(20.0, range=(1.0, 200.0), doc="how often it publishes")


class PoseStand(Node):
    """Publishes the known pose and what it sees at rate_hz."""

    __test__ = False
    name = "posestand"
    Params = PoseStandParams

    def setup(self) -> None:
        self.pose = known_pose()
        self.pubs = {t: self.publisher(t) for t in ("joint_states", "imu/data", "position", "ball_relative",
                                                    "obstacles_relative", "ground_truth")}
        self.timer(self.tick, rate_hz=self.params.rate_hz)

    def tick(self) -> None:
        p = self.pubs
        p["joint_states"].publish(schemas.make("sensor_msgs/msg/JointState", header=header(), name=list(self.pose),
                                               position=list(self.pose.values())))
        level = schemas.make("geometry_msgs/msg/Quaternion", w=1.0)
        p["imu/data"].publish(schemas.make("sensor_msgs/msg/Imu", header=header("imu_frame"), orientation=level))
        pose = schemas.make("geometry_msgs/msg/Pose2D", x=self.params.x, y=self.params.y, theta=self.params.theta)
        p["position"].publish(schemas.make(HL + "Position2D", header=header("map"), pose=pose, confidence=1.0))
        ball = schemas.make("geometry_msgs/msg/Point", x=BALL[0], y=BALL[1])
        p["ball_relative"].publish(schemas.make(HL + "BallRelative", header=header("base_footprint"),
                                                ball_relative=ball, confidence=0.9))
        where = schemas.make("geometry_msgs/msg/Point", x=OBSTACLE[0], y=OBSTACLE[1])
        obstacle = schemas.make(HL + "ObstacleRelative", color=2, position=where, width=0.3, height=0.6,
                                confidence=0.8)
        p["obstacles_relative"].publish(schemas.make(HL + "ObstaclesRelative", header=header("base_footprint"),
                                                     obstacles=[obstacle]))
        torso = schemas.make("geometry_msgs/msg/Pose", position=schemas.make("geometry_msgs/msg/Point", x=TRUE_TORSO[0],
                                                                            y=TRUE_TORSO[1], z=TRUE_TORSO[2]),
                             orientation=level)
        true_ball = schemas.make("geometry_msgs/msg/Point", x=TRUE_BALL[0], y=TRUE_BALL[1], z=TRUE_BALL[2])
        p["ground_truth"].publish(schemas.make("pitchside_msgs/msg/GroundTruth", header=header("map"),
                                               robot_ids=[self.robot_id], robot_poses=[torso], ball=true_ball))
