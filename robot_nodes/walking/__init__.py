"""pitchside walking node: omnidirectional walk engine -> leg joint goals, odometry."""

from robot_nodes.walking.engine import Phase, Pose2D, WalkEngine, WalkOutput
from robot_nodes.walking.gait import WalkParams
from robot_nodes.walking.kinematics import KinematicsError, LegGeometry, LegKinematics

__all__ = ["KinematicsError", "LegGeometry", "LegKinematics", "Phase", "Pose2D", "WalkEngine", "WalkOutput",
           "WalkParams"]
