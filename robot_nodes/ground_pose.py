"""A pose on the ground (x, y, heading) with the two transforms every node that walks somewhere needs: a point seen
from the pose, and a point given relative to it. The field frame, the odometry frame: whichever the pose is in."""

from __future__ import annotations

import math
from dataclasses import dataclass


def wrap(angle: float) -> float:
    """The angle in (-pi, pi]."""
    return math.atan2(math.sin(angle), math.cos(angle))


def heading(x: float, y: float, z: float, w: float) -> float:
    """The yaw (rad) of an orientation quaternion: where it points on the ground."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


@dataclass(frozen=True)
class GroundPose:
    x: float
    y: float
    yaw: float  # rad, 0 along +x, counter-clockwise

    def relative(self, x: float, y: float) -> tuple[float, float]:
        """A point of the pose's frame seen from the pose (x forward, y left)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        dx, dy = x - self.x, y - self.y
        return c * dx + s * dy, -s * dx + c * dy

    def absolute(self, forward: float, left: float) -> tuple[float, float]:
        """A point given relative to the pose, in the pose's frame."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return self.x + c * forward - s * left, self.y + s * forward + c * left


OWN_HALVES = ["-x", "+x"]
OWN_HALF_DOC = ("the half the team defends in the frame of `position` and team data: -x (a localization in the team's "
                "own frame, the RoboCup convention, as the cm730 node's stand-in gives by default) or +x (the away "
                "team of `pitchside match`, whose stand-ins give both teams the world's frame)")


def team_frame(x: float, y: float, yaw: float, own_half: str) -> tuple[float, float, float]:
    """A field pose in the team's own frame (own goal at -x): turned half round when the team defends +x."""
    if own_half == "+x":
        return -x, -y, wrap(yaw + math.pi)
    return x, y, yaw
