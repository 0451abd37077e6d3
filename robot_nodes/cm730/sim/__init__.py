"""The MuJoCo simulation of the servo bus: a kid-size field, a ball and N Minibots (robot1..robotN)."""

from robot_nodes.cm730.sim.field import KID_SIZE, FieldDimensions
from robot_nodes.cm730.sim.scene import MINIBOT_URDF, PhysicsConfig, Placement
from robot_nodes.cm730.sim.world import STAND_POSE, ImuNoise, RobotHandle, SimError, SimWorld

__all__ = [
    "KID_SIZE",
    "MINIBOT_URDF",
    "STAND_POSE",
    "FieldDimensions",
    "ImuNoise",
    "PhysicsConfig",
    "Placement",
    "RobotHandle",
    "SimError",
    "SimWorld",
]
