"""The MuJoCo simulation of the servo bus: a kid-size field, a ball and N Minibots (robot1..robotN)."""

import os

# offscreen rendering needs the GL backend chosen before mujoco is first imported (EGL works on the CPU here)
os.environ.setdefault("MUJOCO_GL", "egl")


from robot_nodes.cm730.sim.field import KID_SIZE, FieldDimensions
from robot_nodes.cm730.sim.perception import DetectionNoise, GroundTruthVision, Observation, observe_all
from robot_nodes.cm730.sim.runner import CameraClient, CameraFrame, SimRunner
from robot_nodes.cm730.sim.scene import MINIBOT_URDF, PhysicsConfig, Placement
from robot_nodes.cm730.sim.world import STAND_POSE, ImuNoise, RobotHandle, SimError, SimWorld

__all__ = [
    "KID_SIZE",
    "MINIBOT_URDF",
    "STAND_POSE",
    "CameraClient",
    "CameraFrame",
    "DetectionNoise",
    "FieldDimensions",
    "GroundTruthVision",
    "ImuNoise",
    "Observation",
    "PhysicsConfig",
    "Placement",
    "RobotHandle",
    "SimError",
    "SimRunner",
    "SimWorld",
    "observe_all",
]
