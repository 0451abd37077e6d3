"""Joint limits from the robot's URDF and the one clamp every motor goal passes before any servo backend sees it.

One mistyped or malformed `motor_goals` must not drive a knee into the robot's own body, on the simulated or the
real bus alike, so the rule lives here once: positions go into [lower + margin, upper - margin] of their revolute
joint, speeds are capped at the joint's `<limit velocity>`.

The URDF is read with the standard library's XML parser, not yourdfpy: the cm730 node starts on the robot's own
computer (again after every crash), and yourdfpy imports trimesh and friends (about 0.6 s) to read twenty
`<limit>` tags. tests/test_joint_limits.py checks this reader against yourdfpy on the Minibot and on Wolfgang.

Decisions, each explicit:
- revolute: position clamped to [lower + margin, upper - margin]; a range narrower than twice the margin
  shrinks to its middle. Missing lower/upper are 0, as the URDF spec says; a revolute joint without `<limit>`
  (the spec requires one) is an error.
- continuous: no position limit (it turns all the way round); its speed is still capped if it has a velocity.
- prismatic, fixed, floating, planar: not a servo joint here; like a joint the URDF does not know at all, the
  node refuses goals for it (`GoalLimits.knows`).
- velocity: a goal without velocity, or with 0 (which a Dynamixel reads as "as fast as you can"), or with a
  non-finite one, moves at the URDF velocity; a faster one is capped to it (and counted). A joint whose URDF has
  no positive velocity has no speed cap: its goal speed passes through (0 = the servo's maximum).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

SERVO_JOINT_TYPES = ("revolute", "continuous")


class JointLimitsError(ValueError):
    """The URDF cannot be read, or its limits make no sense; the message names the file and the joint."""


@dataclass(frozen=True, slots=True)
class JointLimit:
    """One joint as the URDF limits it: rad, rad/s; -inf/inf where there is no limit."""

    lower: float
    upper: float
    velocity: float

    @property
    def bounded(self) -> bool:
        return math.isfinite(self.lower) and math.isfinite(self.upper)


def _number(joint: str, element: ET.Element, key: str, default: float | None, path: Path) -> float | None:
    raw = element.get(key)
    if raw is None:
        return default
    try:
        value = float(raw)
    except ValueError:
        raise JointLimitsError(f"{path}: joint {joint!r}: {key}={raw!r} is not a number") from None
    if not math.isfinite(value):
        raise JointLimitsError(f"{path}: joint {joint!r}: {key}={raw!r} is not finite")
    return value


def read_urdf_limits(path: str | Path) -> dict[str, JointLimit]:
    """Limits of the revolute and continuous joints of a URDF file, by joint name."""
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise JointLimitsError(f"cannot read URDF {path}: {exc}") from None
    if root.tag != "robot":
        raise JointLimitsError(f"{path}: not a URDF (root element <{root.tag}>, expected <robot>)")
    limits: dict[str, JointLimit] = {}
    seen: set[str] = set()
    # direct children only: <transmission> and <gazebo> blocks hold <joint name=...> references of their own
    for joint in root.findall("joint"):
        name, kind = joint.get("name"), joint.get("type")
        if not name:
            raise JointLimitsError(f"{path}: a <joint> without a name")
        if name in seen:
            raise JointLimitsError(f"{path}: joint {name!r} defined twice")
        seen.add(name)
        if kind not in SERVO_JOINT_TYPES:
            continue
        limit = joint.find("limit")
        if limit is None:
            if kind == "revolute":
                raise JointLimitsError(f"{path}: revolute joint {name!r} has no <limit> (the URDF spec requires one)")
            limits[name] = JointLimit(-math.inf, math.inf, math.inf)
            continue
        velocity = _number(name, limit, "velocity", None, path)
        speed = velocity if velocity is not None and velocity > 0.0 else math.inf
        if kind == "continuous":
            limits[name] = JointLimit(-math.inf, math.inf, speed)
            continue
        lower = _number(name, limit, "lower", 0.0, path)
        upper = _number(name, limit, "upper", 0.0, path)
        assert lower is not None and upper is not None
        if lower > upper:
            raise JointLimitsError(f"{path}: joint {name!r}: lower {lower} is above upper {upper}")
        limits[name] = JointLimit(lower, upper, speed)
    if not limits:
        raise JointLimitsError(f"{path}: no revolute or continuous joint: is this the robot's URDF?")
    return limits


@dataclass(slots=True)
class ClampedGoals:
    """What the clamp made of one set of goals; arrays are index-aligned with the joint names given."""

    positions: np.ndarray
    velocities: np.ndarray | None
    excess: np.ndarray  # rad the asked position lay beyond the safe range, 0 where it was inside
    capped: np.ndarray  # bool: an asked speed above the joint's URDF velocity (or not a number)

    @property
    def clamped(self) -> np.ndarray:
        return np.asarray(self.excess > 0.0)

    @property
    def changed(self) -> bool:
        return bool(self.clamped.any() or self.capped.any())


class GoalLimits:
    """The clamp: position goals into each joint's safe range (URDF limits minus the margin), speeds capped."""

    def __init__(self, limits: dict[str, JointLimit], margin_rad: float = 0.0, source: str = "") -> None:
        if not math.isfinite(margin_rad) or margin_rad < 0.0:
            raise JointLimitsError(f"margin must be a finite angle >= 0, got {margin_rad!r}")
        self.limits = dict(limits)
        self.margin = margin_rad
        self.source = source
        self._index = {name: i for i, name in enumerate(self.limits)}
        lower = np.array([lim.lower for lim in self.limits.values()], dtype=float)
        upper = np.array([lim.upper for lim in self.limits.values()], dtype=float)
        with np.errstate(invalid="ignore"):  # -inf + inf of continuous joints: their middle is not used
            middle = np.where(np.isfinite(lower), (lower + upper) / 2.0, 0.0)
        # a range narrower than twice the margin shrinks to its middle rather than turning inside out
        self._lower = np.minimum(lower + margin_rad, middle)
        self._upper = np.maximum(upper - margin_rad, middle)
        self._speed = np.array([lim.velocity for lim in self.limits.values()], dtype=float)
        self._rows: dict[tuple[str, ...], tuple[np.ndarray, ...]] = {}  # per joint-name list: its slices

    def _slices(self, names: Sequence[str]) -> tuple[np.ndarray, ...]:
        """lower, upper, speed, has-speed and unset-speed of these joints; goal streams repeat their joint lists,
        so they are cut once per list (a bounded cache: a flood of odd lists only costs the cutting)."""
        key = tuple(names)
        rows = self._rows.get(key)
        if rows is None:
            idx = np.array([self._index[n] for n in names], dtype=int)
            top = self._speed[idx]
            limited = np.isfinite(top)
            rows = (self._lower[idx], self._upper[idx], top, limited, np.where(limited, top, 0.0))
            if len(self._rows) < 64:
                self._rows[key] = rows
        return rows

    @classmethod
    def from_urdf(cls, path: str | Path, margin_deg: float) -> GoalLimits:
        return cls(read_urdf_limits(path), math.radians(margin_deg), str(path))

    def knows(self, joint: str) -> bool:
        return joint in self._index

    def safe_range(self, joint: str) -> tuple[float, float]:
        """[lower, upper] in rad a goal of this joint is clamped to; (-inf, inf) for a continuous joint."""
        i = self._index[joint]
        return float(self._lower[i]), float(self._upper[i])

    def speed_limit(self, joint: str) -> float:
        """rad/s; inf where the URDF gives no velocity."""
        return float(self._speed[self._index[joint]])

    def clamp(self, names: Sequence[str], positions: np.ndarray, velocities: np.ndarray | None = None) -> ClampedGoals:
        """Every name must be known (see `knows`); positions must be finite (the node drops the others first)."""
        lo, hi, top, limited, unset_speed = self._slices(names)  # unset speed 0: the servo's "as fast as it can"
        asked = np.asarray(positions, dtype=float).reshape(-1)
        clamped = np.clip(asked, lo, hi)
        excess = np.abs(asked - clamped)
        if velocities is None:
            speeds = unset_speed.copy() if limited.any() else None
            capped = np.zeros(len(asked), dtype=bool)
        else:
            v = np.abs(np.asarray(velocities, dtype=float).reshape(-1))
            finite = np.isfinite(v)
            capped = limited & ((~finite) | (v > top))
            unset = (~finite) | (v == 0.0)
            speeds = np.where(unset, unset_speed, np.minimum(v, top))
        return ClampedGoals(positions=clamped, velocities=speeds, excess=excess, capped=capped)

    def describe(self) -> str:
        bounded = sum(1 for lim in self.limits.values() if lim.bounded)
        speeds = int(np.isfinite(self._speed).sum())
        return (f"{self.source or 'limits'}: {bounded} joints clamped {math.degrees(self.margin):g} deg inside "
                f"their limits, {len(self.limits) - bounded} continuous, speeds capped on {speeds}")


@dataclass(slots=True)
class _Worst:
    joint: str = ""
    excess: float = 0.0  # rad beyond the safe range
    count: int = 0  # clamped positions in the period
    speeds: int = 0  # capped speeds in the period


class ClampTally:
    """Counts clamps per joint, and says at most once per `every_s` which joint was clamped worst and by how much,
    so a stream of bad goals at 100 Hz is one line every few seconds rather than a hundred errors a second."""

    def __init__(self, every_s: float = 5.0) -> None:
        self.every_s = every_s
        self.positions: dict[str, int] = {}  # clamped position goals per joint
        self.speeds: dict[str, int] = {}  # capped speeds per joint
        self.worst_joint = ""
        self.worst_excess = 0.0  # rad, the largest clamp since start
        self._period = _Worst()
        self._last_report = -math.inf

    @property
    def total_positions(self) -> int:
        return sum(self.positions.values())

    @property
    def total_speeds(self) -> int:
        return sum(self.speeds.values())

    def add(self, names: Sequence[str], result: ClampedGoals, now: float) -> str | None:
        """Counts one clamp result; returns a report when one is due (the first clamp, then every `every_s`)."""
        if not result.changed:
            return None
        period = self._period
        for i in np.flatnonzero(result.clamped).tolist():
            joint, excess = names[i], float(result.excess[i])
            self.positions[joint] = self.positions.get(joint, 0) + 1
            period.count += 1
            if excess > period.excess:
                period.joint, period.excess = joint, excess
            if excess > self.worst_excess:
                self.worst_joint, self.worst_excess = joint, excess
        for i in np.flatnonzero(result.capped).tolist():
            self.speeds[names[i]] = self.speeds.get(names[i], 0) + 1
            period.speeds += 1
        if now - self._last_report < self.every_s:
            return None
        self._last_report = now
        self._period = _Worst()
        parts = []
        if period.count:
            parts.append(f"clamped {period.count} position goal(s) to the joint limits, worst {period.joint} "
                         f"{period.excess:.3f} rad ({math.degrees(period.excess):.1f} deg) beyond its safe range")
        if period.speeds:
            parts.append(f"capped {period.speeds} goal speed(s) to the URDF velocity")
        return "motor_goals: " + "; ".join(parts) + f" (reported at most every {self.every_s:g} s)"

    def by_joint(self) -> str:
        """'LKnee=12 RKnee=3', most clamped first."""
        return " ".join(f"{j}={n}" for j, n in sorted(self.positions.items(), key=lambda kv: (-kv[1], kv[0])))

    def worst(self) -> str:
        if not self.worst_joint:
            return ""
        return f"{self.worst_joint} {self.worst_excess:.3f} rad ({math.degrees(self.worst_excess):.1f} deg)"
