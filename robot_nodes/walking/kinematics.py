"""Analytic inverse kinematics of a 6-joint humanoid leg (hip yaw-roll-pitch, knee, ankle pitch-roll) from a URDF.

The leg is solved in a canonical chain (Kajita et al., "Introduction to Humanoid Robotics", IK_leg):
hip Rz(yaw) Rx(roll) Ry(pitch), thigh, Ry(knee), shank, Ry(ankle pitch) Rx(ankle roll), sole, with every
pitch positive about +y. The URDF's axis signs and the knee's zero offset map canonical angles to joint values,
so a robot with Wolfgang's conventions (mirrored signs, hyperextended knee zero) and any other layout with the
same joint order are handled alike. Link lengths come from the URDF, never typed in.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import robots

MINIBOT_URDF = robots.urdf("minibot")
LEG_JOINTS = ("HipYaw", "HipRoll", "HipPitch", "Knee", "AnklePitch", "AnkleRoll")
SIDES = ("L", "R")


class KinematicsError(ValueError):
    """The URDF does not describe a leg this solver handles; the message says what is missing or odd."""


def _matrix(*rows: float) -> np.ndarray:
    """A 3x3 matrix from its nine entries, row by row (a flat tuple: faster than nested lists, and this runs at
    100 Hz per robot)."""
    return np.array(rows).reshape(3, 3)


def rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return _matrix(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)


def rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return _matrix(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return _matrix(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)


def rot_zxy(yaw: float, roll: float, pitch: float) -> np.ndarray:
    """Rz(yaw) Rx(roll) Ry(pitch) in one matrix: the hip's three joints."""
    cz, sz, cx, sx, cy, sy = math.cos(yaw), math.sin(yaw), math.cos(roll), math.sin(roll), math.cos(pitch), \
        math.sin(pitch)
    return _matrix(cz * cy - sz * sx * sy, -sz * cx, cz * sy + sz * sx * cy,
                   sz * cy + cz * sx * sy, cz * cx, sz * sy - cz * sx * cy,
                   -cx * sy, sx, cx * cy)


def rot_yx(pitch: float, roll: float) -> np.ndarray:
    """Ry(pitch) Rx(roll) in one matrix: the ankle's two joints."""
    cy, sy, cx, sx = math.cos(pitch), math.sin(pitch), math.cos(roll), math.sin(roll)
    return _matrix(cy, sy * sx, sy * cx, 0.0, cx, -sx, -sy, cy * sx, cy * cx)


def rot_xy(roll: float, pitch: float) -> np.ndarray:
    """Rx(roll) Ry(pitch) in one matrix."""
    cx, sx, cy, sy = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    return _matrix(cy, 0.0, sy, sx * sy, cx, -sx * cy, -cx * sy, sx, cx * cy)


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF convention: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    return rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)


@dataclass(frozen=True)
class LegGeometry:
    """One leg as the solver sees it; every number read from the robot description."""

    side: str  # "L" or "R"
    hip: np.ndarray  # hip roll/pitch centre in base_link (yaw axis passes through it, vertical)
    thigh: float  # hip pitch -> knee, m
    shank: float  # knee -> ankle pitch, m
    sole: np.ndarray  # ankle -> sole frame, in the foot frame
    signs: dict[str, float]  # joint name suffix -> +1/-1 (URDF axis along or against the canonical axis)
    knee_offset: float  # canonical knee angle at joint value 0 (Wolfgang: -0.2618, hyperextended)

    def __post_init__(self) -> None:
        # the signs in joint order and the knee's offset as a vector, once: the walk uses them at 100 Hz
        object.__setattr__(self, "_sign_vector", np.array([self.signs[j] for j in LEG_JOINTS]))
        object.__setattr__(self, "_offset_vector", np.array([0.0, 0.0, 0.0, self.knee_offset, 0.0, 0.0]))

    def joint_names(self) -> list[str]:
        return [self.side + j for j in LEG_JOINTS]

    def to_joints(self, canonical: np.ndarray) -> np.ndarray:
        """Canonical angles [yaw, roll, pitch, knee, ankle pitch, ankle roll] -> the robot's joint values."""
        return (np.asarray(canonical, dtype=float) - self._offset_vector) * self._sign_vector  # type: ignore[attr-defined]

    def to_canonical(self, joints: np.ndarray) -> np.ndarray:
        return np.asarray(joints, dtype=float) * self._sign_vector + self._offset_vector  # type: ignore[attr-defined]

    def ik(self, position: np.ndarray, rotation: np.ndarray) -> np.ndarray:
        """Joint values that put the sole frame at (position, rotation) in base_link. Unreachable targets are
        solved for the nearest stretched leg (knee straight), never NaN."""
        r_foot = np.asarray(rotation, dtype=float)
        ankle = np.asarray(position, dtype=float) - r_foot @ self.sole
        rx, ry, rz = (r_foot.T @ (self.hip - ankle)).tolist()  # the hip seen from the ankle, in the foot frame
        a, b = self.thigh, self.shank
        c = max(math.sqrt(rx * rx + ry * ry + rz * rz), 1e-6)
        cos_knee = (c * c - a * a - b * b) / (2.0 * a * b)
        knee = math.acos(min(1.0, max(-1.0, cos_knee)))
        ankle_roll = math.atan2(ry, rz)
        if ankle_roll > math.pi / 2:
            ankle_roll -= math.pi
        elif ankle_roll < -math.pi / 2:
            ankle_roll += math.pi
        sub = math.asin(min(1.0, max(-1.0, a / c * math.sin(math.pi - knee))))
        ankle_pitch = -math.atan2(rx, math.copysign(math.hypot(ry, rz), rz)) - sub
        (_, h01, _), (_, h11, _), (h20, h21, h22) = (r_foot @ rot_xy(-ankle_roll, -ankle_pitch - knee)).tolist()
        yaw = math.atan2(-h01, h11)
        cz, sz = math.cos(yaw), math.sin(yaw)
        roll = math.atan2(h21, -h01 * sz + h11 * cz)
        pitch = math.atan2(-h20, h22)
        return self.to_joints(np.array((yaw, roll, pitch, knee, ankle_pitch, ankle_roll)))

    def fk(self, joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Sole (position, rotation) in base_link for the robot's joint values (the canonical chain)."""
        yaw, roll, pitch, knee, ankle_pitch, ankle_roll = self.to_canonical(joints).tolist()
        r = rot_zxy(yaw, roll, pitch)
        p = self.hip - self.thigh * r[:, 2]
        r = r @ rot_y(knee)
        p = p - self.shank * r[:, 2]
        r = r @ rot_yx(ankle_pitch, ankle_roll)
        return p + r @ self.sole, r


@dataclass(frozen=True)
class LegKinematics:
    """Both legs of a robot."""

    left: LegGeometry
    right: LegGeometry

    def leg(self, side: str) -> LegGeometry:
        return self.left if side == "L" else self.right

    @classmethod
    def from_urdf(cls, path: Path = MINIBOT_URDF) -> LegKinematics:
        try:
            root = ET.parse(path).getroot()
        except (OSError, ET.ParseError) as exc:
            raise KinematicsError(f"cannot read URDF {path}: {exc}") from exc
        joints = {j.get("name"): j for j in root.iter("joint")}
        return cls(_leg_from(joints, "L"), _leg_from(joints, "R"))


def _vec(element: ET.Element | None, attr: str, default: str = "0 0 0") -> np.ndarray:
    text = element.get(attr, default) if element is not None else default
    return np.array([float(v) for v in text.split()])


def _leg_from(joints: dict[str | None, ET.Element], side: str) -> LegGeometry:
    def joint(suffix: str) -> ET.Element:
        j = joints.get(side + suffix)
        if j is None:
            raise KinematicsError(f"URDF has no joint {side + suffix}")
        return j

    canonical_axis = {"HipYaw": 2, "HipRoll": 0, "HipPitch": 1, "Knee": 1, "AnklePitch": 1, "AnkleRoll": 0}
    signs: dict[str, float] = {}
    origins: dict[str, np.ndarray] = {}
    rpys: dict[str, np.ndarray] = {}
    for name in LEG_JOINTS:
        j = joint(name)
        axis = _vec(j.find("axis"), "xyz", "1 0 0")
        k = canonical_axis[name]
        if abs(abs(axis[k]) - 1.0) > 1e-6 or np.linalg.norm(axis) > 1.0 + 1e-6:
            raise KinematicsError(f"{side + name}: axis {axis} is not along the leg layout's axis {'xyz'[k]}")
        signs[name] = float(np.sign(axis[k]))
        origins[name] = _vec(j.find("origin"), "xyz")
        rpys[name] = _vec(j.find("origin"), "rpy")
    for name in ("HipYaw", "HipRoll", "HipPitch", "AnklePitch", "AnkleRoll"):
        if np.abs(rpys[name]).max() > 1e-6:
            raise KinematicsError(f"{side + name}: a rotated joint origin is only supported at the knee")
    if abs(rpys["Knee"][0]) > 1e-6 or abs(rpys["Knee"][2]) > 1e-6:
        raise KinematicsError(f"{side}Knee: origin may only rotate about y (a zero offset)")
    for name in ("HipPitch", "Knee", "AnklePitch", "AnkleRoll"):
        if name in ("Knee", "AnklePitch"):
            if np.abs(origins[name][:2]).max() > 1e-6:
                raise KinematicsError(f"{side + name}: origin must lie straight below the previous joint")
        elif np.abs(origins[name]).max() > 1e-6:
            raise KinematicsError(f"{side + name}: must share its origin with the previous joint")
    if np.abs(origins["HipRoll"][:2]).max() > 1e-6:
        raise KinematicsError(f"{side}HipRoll: origin must lie on the hip yaw axis")
    sole_joint = next((j for j in joints.values() if j.find("parent") is not None
                       and j.find("parent").get("link") == joint("AnkleRoll").find("child").get("link")  # type: ignore[union-attr]
                       and "sole" in (j.find("child").get("link") or "")), None)  # type: ignore[union-attr]
    if sole_joint is None:
        raise KinematicsError(f"URDF has no sole frame below {side}AnkleRoll")
    parent = joint("HipYaw").find("parent")
    if parent is None or parent.get("link") not in ("torso", "base_link"):
        raise KinematicsError(f"{side}HipYaw must hang from the torso")
    return LegGeometry(
        side=side,
        hip=origins["HipYaw"] + origins["HipRoll"],
        thigh=float(-origins["Knee"][2]),
        shank=float(-origins["AnklePitch"][2]),
        sole=_vec(sole_joint.find("origin"), "xyz"),
        signs=signs,
        knee_offset=float(rpys["Knee"][1]),
    )
