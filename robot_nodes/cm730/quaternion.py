"""Quaternions (x, y, z, w) on plain floats: the IMUs turn by small rotations at each reading, 100 times a second
per robot (the CM-730's filter on the robot, the simulated IMU's noise in the world), where numpy's per-call cost
would be most of the work."""

from __future__ import annotations

import math
from collections.abc import Sequence

Quaternion = tuple[float, float, float, float]


def multiply(a: Sequence[float], b: Sequence[float]) -> Quaternion:
    """The Hamilton product a b: b's rotation in a's frame, then a's."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def from_rotation_vector(rx: float, ry: float, rz: float) -> Quaternion:
    """The rotation by |r| radians about r (the identity for a vector shorter than 1e-12)."""
    angle = math.sqrt(rx * rx + ry * ry + rz * rz)
    if angle < 1e-12:
        return (0.0, 0.0, 0.0, 1.0)
    s = math.sin(angle / 2.0) / angle
    return (rx * s, ry * s, rz * s, math.cos(angle / 2.0))
