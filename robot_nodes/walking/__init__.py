"""pitchside walking node: omnidirectional walk engine -> leg joint goals, odometry."""

from robot_nodes.walking.engine import Phase, WalkEngine, WalkOutput
from robot_nodes.walking.gait import WalkParams
from robot_nodes.walking.kinematics import KinematicsError, LegGeometry, LegKinematics
from robot_nodes.walking.odometry import LegOdometry
from robot_nodes.walking.pose import Pose2D

__all__ = ["KinematicsError", "LegGeometry", "LegKinematics", "LegOdometry", "Phase", "Pose2D", "WalkEngine",
           "WalkOutput", "WalkParams"]
