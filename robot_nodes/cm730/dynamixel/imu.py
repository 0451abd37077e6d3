"""CM-730 IMU: raw 10-bit gyro/accelerometer words to SI units, orientation from a complementary filter.

The filter integrates the gyro and, while the measured acceleration is close to 1 g, pulls roll and
pitch towards the accelerometer's gravity direction by `gain` of the error per update (Mahony-style
proportional correction without an integral term). Yaw is the integrated gyro only and drifts: the
CM-730 has no magnetometer. The first reading initialises roll/pitch from the accelerometer.
"""

from __future__ import annotations

import math

import numpy as np

from .. import quaternion
from ..backend import ImuReading

GRAVITY = 9.80665
GYRO_FULL_SCALE_RAD_S = math.radians(1600.0)  # (raw - 512) / 512 * 1600 deg/s
ACCEL_FULL_SCALE_M_S2 = 4.0 * GRAVITY  # (raw - 512) / 512 * 4 g


def gyro_rad_s(raw_xyz: tuple[int, int, int]) -> np.ndarray:
    return (np.asarray(raw_xyz, dtype=float) - 512.0) / 512.0 * GYRO_FULL_SCALE_RAD_S


def accel_m_s2(raw_xyz: tuple[int, int, int]) -> np.ndarray:
    return (np.asarray(raw_xyz, dtype=float) - 512.0) / 512.0 * ACCEL_FULL_SCALE_M_S2


def accel_raw(m_s2: float) -> int:
    """Inverse of accel_m_s2 for one axis (emulators and tests)."""
    return round(512 + m_s2 / ACCEL_FULL_SCALE_M_S2 * 512)


def gyro_raw(rad_s: float) -> int:
    return round(512 + rad_s / GYRO_FULL_SCALE_RAD_S * 512)


def world_up_in_body(q: np.ndarray) -> np.ndarray:
    """Third row of R(q): the world z axis expressed in the body frame."""
    x, y, z, w = q
    return np.array([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])


def tilt_quaternion(accel: np.ndarray) -> np.ndarray:
    """Orientation with zero yaw whose up vector matches the accelerometer (body at rest)."""
    ax, ay, az = accel / np.linalg.norm(accel)
    roll = math.atan2(ay, az)
    pitch = math.atan2(-ax, math.hypot(ay, az))
    cr, sr, cp, sp = math.cos(roll / 2), math.sin(roll / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    return np.array([sr * cp, cr * sp, -sr * sp, cr * cp])


class ComplementaryFilter:
    """Gyro integration with a proportional pull of roll/pitch towards gravity."""

    def __init__(self, gain: float = 0.02) -> None:
        self.gain = gain
        self.q: np.ndarray | None = None

    def update(self, gyro: np.ndarray, accel: np.ndarray, dt: float) -> np.ndarray:
        norm = float(np.linalg.norm(accel))
        if self.q is None:
            if norm < 1e-6:
                return np.array([0.0, 0.0, 0.0, 1.0])
            self.q = tilt_quaternion(accel)
            return self.q.copy()
        dt = min(max(dt, 0.0), 0.1)  # a stalled loop must not spin the estimate
        step = gyro * dt
        if 0.5 * GRAVITY < norm < 1.5 * GRAVITY:
            step = step + self.gain * np.cross(accel / norm, world_up_in_body(self.q))
        turned = quaternion.multiply(self.q.tolist(), quaternion.from_rotation_vector(*step.tolist()))
        q: np.ndarray = np.asarray(turned, dtype=float)
        self.q = q / np.linalg.norm(q)
        return self.q.copy()


class CM730Imu:
    """Turns the CM-730 table bytes into ImuReading; axis signs adapt to how the board is mounted."""

    def __init__(self, gain: float = 0.02, gyro_sign: tuple[float, float, float] = (1.0, 1.0, 1.0),
                 accel_sign: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> None:
        self.filter = ComplementaryFilter(gain)
        self.gyro_sign = np.asarray(gyro_sign, dtype=float)
        self.accel_sign = np.asarray(accel_sign, dtype=float)
        self._last_t: float | None = None

    def reading(self, gyro_zyx_raw: tuple[int, int, int], accel_xyz_raw: tuple[int, int, int],
                t: float) -> ImuReading:
        gz, gy, gx = gyro_zyx_raw  # the CM-730 stores the gyro words Z, Y, X
        gyro = gyro_rad_s((gx, gy, gz)) * self.gyro_sign
        accel = accel_m_s2(accel_xyz_raw) * self.accel_sign
        dt = 0.0 if self._last_t is None else t - self._last_t
        self._last_t = t
        q = self.filter.update(gyro, accel, dt)
        return ImuReading(orientation_xyzw=q, angular_velocity=gyro, linear_acceleration=accel)
