"""Keyframe animation to joint trajectories: one monotone cubic (or linear) curve per joint, sampled at time t.

Each joint's curve starts at its measured position at t=0 and passes through every keyframe
that names it: at ``t_k`` (the sum of all earlier durations and pauses plus this duration) and,
when the keyframe pauses, again at ``t_k + pause`` so the joint holds still. A joint whose
measured position is unknown starts at its first goal instead (it jumps there at t=0).

The cubic is a clamped monotone Hermite spline (Fritsch-Butland slopes, as in PCHIP, with zero
velocity at both ends): it never overshoots the neighbouring points, so a servo is never asked
to go past the poses the animator recorded.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from wire.animation.animation_file import Animation

INTERPOLATIONS = ("spline", "linear")
_SAME_TIME = 1e-9


def _merge(times: list[float], values: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """Points at the same time collapse to the later one (a zero duration is a jump)."""
    t_out: list[float] = []
    y_out: list[float] = []
    for t, y in zip(times, values, strict=True):
        if t_out and t - t_out[-1] <= _SAME_TIME:
            y_out[-1] = y
        else:
            t_out.append(t)
            y_out.append(y)
    return np.asarray(t_out, dtype=float), np.asarray(y_out, dtype=float)


def monotone_slopes(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Hermite slopes that keep the cubic monotone between points; zero at both ends."""
    m = np.zeros_like(y)
    if len(t) < 3:
        return m
    h = np.diff(t)
    d = np.diff(y) / h
    for k in range(1, len(t) - 1):
        if d[k - 1] * d[k] <= 0:
            continue  # local extremum or flat: stop here so the curve cannot overshoot
        w1 = 2 * h[k] + h[k - 1]
        w2 = h[k] + 2 * h[k - 1]
        m[k] = (w1 + w2) * d[k - 1] * d[k] / (w1 * d[k] + w2 * d[k - 1])  # weighted harmonic mean
    return m


@dataclass(frozen=True)
class JointCurve:
    """One joint's position over time (whatever unit the points are in)."""

    times: np.ndarray
    values: np.ndarray
    slopes: np.ndarray
    linear: bool = False

    @classmethod
    def through(cls, times: list[float], values: list[float], interpolation: str = "spline") -> JointCurve:
        if interpolation not in INTERPOLATIONS:
            raise ValueError(f"interpolation must be one of {INTERPOLATIONS}, got {interpolation!r}")
        t, y = _merge(times, values)
        linear = interpolation == "linear"
        slopes = np.zeros_like(y) if linear else monotone_slopes(t, y)
        return cls(t, y, slopes, linear)

    def __call__(self, at: float) -> float:
        t, y = self.times, self.values
        if at <= t[0]:
            return float(y[0])
        if at >= t[-1]:
            return float(y[-1])
        k = int(np.searchsorted(t, at, side="right")) - 1
        h = t[k + 1] - t[k]
        s = (at - t[k]) / h
        if self.linear:
            return float(y[k] + s * (y[k + 1] - y[k]))
        s2, s3 = s * s, s * s * s
        return float((2 * s3 - 3 * s2 + 1) * y[k] + (s3 - 2 * s2 + s) * h * self.slopes[k]
                     + (-2 * s3 + 3 * s2) * y[k + 1] + (s3 - s2) * h * self.slopes[k + 1])


@dataclass(frozen=True)
class TorqueChange:
    """A keyframe's torque request and the time it applies (end of that keyframe's pause)."""

    time: float
    keyframe: int
    torques: dict[str, float]


class AnimationPlayer:
    """An animation turned into per-joint curves, ready to be sampled (positions in rad)."""

    def __init__(self, anim: Animation, start_positions: Mapping[str, float] | None = None,
                 interpolation: str = "spline") -> None:
        """start_positions: measured joint positions in rad (joint_states); missing joints start at their first goal."""
        self.animation = anim
        self.interpolation = interpolation
        self.joint_names = anim.joints
        start = start_positions or {}
        points: dict[str, tuple[list[float], list[float]]] = {}
        for joint in self.joint_names:
            first_goal = next(kf.goals[joint] for kf in anim.keyframes if joint in kf.goals)
            begin = math.degrees(start[joint]) if joint in start else first_goal
            points[joint] = ([0.0], [begin])
        self.keyframe_times: list[float] = []
        self.torque_changes: list[TorqueChange] = []
        t = 0.0
        for i, kf in enumerate(anim.keyframes):
            t += kf.duration
            self.keyframe_times.append(t)
            for joint, goal in kf.goals.items():
                points[joint][0].append(t)
                points[joint][1].append(goal)
                if kf.pause > 0:
                    points[joint][0].append(t + kf.pause)
                    points[joint][1].append(goal)
            t += kf.pause
            if kf.torque:
                self.torque_changes.append(TorqueChange(t, i, dict(kf.torque)))
        self.duration = t
        self.curves = {j: JointCurve.through(*points[j], interpolation) for j in self.joint_names}

    def positions_deg(self, t: float) -> np.ndarray:
        return np.array([self.curves[j](t) for j in self.joint_names])

    def positions(self, t: float) -> np.ndarray:
        """Joint positions in rad at time t (clamped to [0, duration]), in the order of joint_names."""
        return np.radians(self.positions_deg(t))

    def goals_at(self, t: float) -> dict[str, float]:
        return dict(zip(self.joint_names, self.positions(t).tolist(), strict=True))

    def torque_at(self, t: float) -> dict[str, float]:
        """Every torque request that applies by time t, later ones overriding earlier ones."""
        out: dict[str, float] = {}
        for change in self.torque_changes:
            if change.time > t + _SAME_TIME:
                break
            out.update(change.torques)
        return out

    def percent_done(self, t: float) -> float:
        if self.duration <= 0:
            return 100.0
        return 100.0 * min(max(t / self.duration, 0.0), 1.0)

    def finished(self, t: float) -> bool:
        return t >= self.duration
