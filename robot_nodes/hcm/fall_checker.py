"""Fall detection from the IMU: is the robot falling (and which way), or lying (and on which side)?

Fused angles (Allgeuer & Behnke) avoid the coupling of Euler angles; the scoring follows the Bit-Bots HCM
(specs/hcm.md section 5): near upright a large angular velocity is needed, near the point of no return any
motion away from upright counts.
"""

from __future__ import annotations

import enum
import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass


class Side(enum.Enum):
    FRONT = "front"
    BACK = "back"
    LEFT = "left"
    RIGHT = "right"


@dataclass
class FallThresholds:
    gyro_pitch: float = 7.0  # rad/s needed to call a fall near upright
    gyro_roll: float = 7.0
    no_return_pitch: float = math.radians(45.0)  # past this tilt any motion away from upright is a fall
    no_return_roll: float = math.radians(60.0)
    smoothing: float = 0.04  # s; a single stable reading in this window means "not falling"
    fallen_orientation: float = math.radians(60.0)
    fallen_at_rest_gyro: float = 0.2  # rad/s; lying only counts once the robot has come to rest


def fused_angles(quat_xyzw: Sequence[float]) -> tuple[float, float]:
    """(fused roll, fused pitch) in rad of a body orientation in the gravity-aligned world frame."""
    x, y, z, w = (float(v) for v in quat_xyzw)  # plain floats: 100 times a second, numpy's overhead is the cost
    r31 = 2.0 * (x * z - w * y)  # R[2][0]
    r32 = 2.0 * (y * z + w * x)  # R[2][1]
    pitch = math.asin(max(-1.0, min(1.0, -r31)))
    roll = math.asin(max(-1.0, min(1.0, r32)))
    return roll, pitch


def _axis_score(angle: float, gyro: float, gyro_threshold: float, no_return: float) -> float:
    if math.copysign(1.0, angle) != math.copysign(1.0, gyro) and abs(angle) < no_return:
        return 0.0  # rotating back towards upright
    scale = max((no_return - abs(angle)) / no_return, 0.0)
    if abs(gyro) > gyro_threshold * scale:
        return abs(gyro) * (1.0 - scale)
    return 0.0


class FallChecker:
    """Feed every IMU reading; ask ``falling`` and ``fallen``."""

    def __init__(self, thresholds: FallThresholds | None = None) -> None:
        self.thresholds = thresholds or FallThresholds()
        self._recent: deque[tuple[float, Side | None]] = deque()
        self._gyro: deque[tuple[float, float]] = deque()
        self.roll = 0.0
        self.pitch = 0.0
        self.falling: Side | None = None
        self.fallen: Side | None = None

    def update(self, t: float, quat_xyzw: Sequence[float], gyro: Sequence[float]) -> None:
        th = self.thresholds
        self.roll, self.pitch = fused_angles(quat_xyzw)
        roll_score = _axis_score(self.roll, float(gyro[0]), th.gyro_roll, th.no_return_roll)
        pitch_score = _axis_score(self.pitch, float(gyro[1]), th.gyro_pitch, th.no_return_pitch)
        side: Side | None = None
        if pitch_score > 0.0 or roll_score > 0.0:
            if pitch_score >= roll_score:
                side = Side.FRONT if self.pitch > 0 else Side.BACK
            else:
                side = Side.RIGHT if self.roll > 0 else Side.LEFT
        window = max(th.smoothing, 1e-3)
        self._recent.append((t, side))
        while self._recent and self._recent[0][0] < t - window:
            self._recent.popleft()
        self.falling = side if all(s is not None for _, s in self._recent) else None

        self._gyro.append((t, math.hypot(float(gyro[0]), float(gyro[1]), float(gyro[2]))))
        while self._gyro and self._gyro[0][0] < t - 0.2:
            self._gyro.popleft()
        at_rest = sum(g for _, g in self._gyro) / len(self._gyro) < th.fallen_at_rest_gyro
        self.fallen = self._lying_side() if at_rest else None

    @property
    def leaning(self) -> Side:
        """The side the robot tilts to most, however little and whether at rest or not: which stand-up to try when
        it is propped up (on another robot, a post) between lying and standing, where ``fallen`` says nothing."""
        if abs(self.pitch) >= abs(self.roll):
            return Side.FRONT if self.pitch > 0 else Side.BACK
        return Side.RIGHT if self.roll > 0 else Side.LEFT

    def _lying_side(self) -> Side | None:
        limit = self.thresholds.fallen_orientation
        if self.pitch > limit:
            return Side.FRONT
        if self.pitch < -limit:
            return Side.BACK
        if self.roll > limit:
            return Side.RIGHT
        if self.roll < -limit:
            return Side.LEFT
        return None
