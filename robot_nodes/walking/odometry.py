"""LegOdometry: the torso's travel from the measured joint angles of whichever foot is on the ground."""

from __future__ import annotations

import math

import numpy as np

from robot_nodes.walking.kinematics import LegKinematics
from robot_nodes.walking.pose import Pose2D


class LegOdometry:
    """While a foot stands still on the ground, the torso moves exactly opposite to that foot as seen from the
    torso. Forward kinematics of the measured joints gives that motion; the lower foot is taken as the one on
    the ground. This counts what the legs really did (servo lag, longer steps) rather than what was commanded."""

    def __init__(self, kinematics: LegKinematics) -> None:
        self.kin = kinematics
        self.pose = Pose2D()
        self._last: tuple[str, Pose2D] | None = None
        self._heading: float | None = None
        self._imu_yaw = 0.0

    def update(self, present: dict[str, float], heading: float | None = None) -> Pose2D:
        """Feed measured joint positions and, if known, the IMU's heading (rad), which sees the turns a foot
        slipping on the ground hides from the joints; returns the integrated pose (odom frame)."""
        feet: dict[str, tuple[float, Pose2D]] = {}
        for leg in (self.kin.left, self.kin.right):
            names = leg.joint_names()
            if not all(n in present for n in names):
                return self.pose
            position, rotation = leg.fk(np.array([present[n] for n in names]))
            feet[leg.side] = (float(position[2]), Pose2D(float(position[0]), float(position[1]),
                                                         math.atan2(rotation[1, 0], rotation[0, 0])))
        support = "L" if feet["L"][0] <= feet["R"][0] else "R"
        foot = feet[support][1]
        if self._last is not None and self._last[0] == support:
            self.pose = self.pose.compose(self._last[1].compose(foot.inverse()))
        if heading is not None:
            if self._heading is not None:
                turned = math.atan2(math.sin(heading - self._heading), math.cos(heading - self._heading))
                self._imu_yaw += turned
            self._heading = heading
            self.pose = Pose2D(self.pose.x, self.pose.y, self._imu_yaw)
        self._last = (support, foot)
        return self.pose

    def reset(self) -> None:
        self.pose = Pose2D()
        self._last = None
        self._heading = None
        self._imu_yaw = 0.0
