"""The Bit-Bots keyframe animation file (JSON): parse with clear errors, check against a robot, save."""

from __future__ import annotations

import datetime
import json
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

LAST_EDITED_FORMAT = "%Y-%m-%d %H:%M:%S.%f"
_KNOWN_TOP = {"name", "version", "author", "description", "last_edited", "hostname", "keyframes"}
_KNOWN_KEYFRAME = {"goals", "duration", "pause", "torque", "stabilization_functions", "name", "p"}


class AnimationError(ValueError):
    """What is wrong with an animation: the file, the keyframe (index from 0, and its name) and the problem."""

    def __init__(self, source: str, problem: str, keyframe: int | None = None, keyframe_name: str | None = None):
        self.source = source
        self.problem = problem
        self.keyframe = keyframe
        self.keyframe_name = keyframe_name
        where = source
        if keyframe is not None:
            where += f": keyframe {keyframe}"
            if keyframe_name:
                where += f" ({keyframe_name!r})"
        super().__init__(f"{where}: {problem}")


@dataclass
class Keyframe:
    """One pose of an animation; goals and torque in the file's units (degrees, torque fraction)."""

    goals: dict[str, float] = field(default_factory=dict)
    duration: float = 1.0
    pause: float = 0.0
    torque: dict[str, float] = field(default_factory=dict)
    stabilization_functions: dict[str, str] = field(default_factory=dict)
    name: str | None = None
    p: dict[str, float] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass
class Animation:
    """A whole animation file; unknown top-level keys live in ``extra`` so a save keeps them."""

    name: str
    keyframes: list[Keyframe] = field(default_factory=list)
    version: str = ""
    author: str = ""
    description: str = ""
    last_edited: str = ""
    hostname: str = ""
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def joints(self) -> list[str]:
        """Every joint some keyframe moves, in order of first appearance."""
        seen: dict[str, None] = {}
        for kf in self.keyframes:
            seen.update(dict.fromkeys(kf.goals))
        return list(seen)

    @property
    def duration(self) -> float:
        return sum(kf.duration + kf.pause for kf in self.keyframes)


# -- parsing ------------------------------------------------------------------------------------------
def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _finite(value: Any) -> bool:
    """A number that fits a float and is not NaN or infinite (JSON allows 1e999 and huge integers)."""
    try:
        return _is_number(value) and math.isfinite(value)
    except OverflowError:
        return False


def _time(raw: Mapping[str, Any], key: str, default: float, err: Any) -> float:
    value = raw.get(key, default)
    if not _is_number(value):
        raise err(f"{key} is not a number: {value!r}")
    if not _finite(value) or value < 0:
        raise err(f"{key} must be a finite number >= 0 s, got {value!r}")
    return float(value)


def _numbers(raw: Mapping[str, Any], key: str, what: str, err: Any) -> dict[str, float]:
    table = raw.get(key, {})
    if table is None:
        return {}
    if not isinstance(table, dict):
        raise err(f"{key} must be an object of joint: number, got {type(table).__name__}")
    out = {}
    for joint, value in table.items():
        if not _is_number(value):
            raise err(f"{what} for joint {joint!r} is not a number: {value!r}")
        if not _finite(value):
            raise err(f"{what} for joint {joint!r} is not finite: {value!r}")
        out[joint] = float(value)
    return out


def _parse_keyframe(raw: Any, index: int, source: str) -> Keyframe:
    name = raw.get("name") if isinstance(raw, dict) else None
    label = name if isinstance(name, str) else None

    def err(problem: str) -> AnimationError:
        return AnimationError(source, problem, index, label)

    if not isinstance(raw, dict):
        raise err(f"a keyframe must be an object, got {type(raw).__name__}")
    if name is not None and not isinstance(name, str):
        raise err(f"name must be a string, got {name!r}")
    stab = raw.get("stabilization_functions", {}) or {}
    if not isinstance(stab, dict) or not all(isinstance(v, str) for v in stab.values()):
        raise err("stabilization_functions must be an object of joint: expression string")
    return Keyframe(
        goals=_numbers(raw, "goals", "goal", err),
        duration=_time(raw, "duration", 1.0, err),
        pause=_time(raw, "pause", 0.0, err),
        torque=_numbers(raw, "torque", "torque", err),
        stabilization_functions=dict(stab),
        name=name,
        p=_numbers(raw, "p", "p", err),
        extra={k: v for k, v in raw.items() if k not in _KNOWN_KEYFRAME},
    )


def _text_field(data: Mapping[str, Any], key: str, source: str) -> str:
    value = data.get(key, "")
    if value is None:
        return ""
    if _is_number(value):  # some tools write version as a number
        return str(value)
    if not isinstance(value, str):
        raise AnimationError(source, f"{key} must be a string, got {value!r}")
    return value


def parse_animation(data: Any, source: str = "<animation>") -> Animation:
    """An Animation from decoded JSON; AnimationError names ``source``, the keyframe and the problem."""
    if not isinstance(data, dict):
        raise AnimationError(source, f"the file must hold one JSON object, got {type(data).__name__}")
    name = data.get("name")
    if name is None:
        raise AnimationError(source, "missing 'name'")
    if not isinstance(name, str) or not name.strip():
        raise AnimationError(source, f"'name' must be a non-empty string, got {name!r}")
    keyframes = data.get("keyframes", [])
    if not isinstance(keyframes, list):
        raise AnimationError(source, f"'keyframes' must be a list, got {type(keyframes).__name__}")
    return Animation(
        name=name,
        keyframes=[_parse_keyframe(raw, i, source) for i, raw in enumerate(keyframes)],
        version=_text_field(data, "version", source),
        author=_text_field(data, "author", source),
        description=_text_field(data, "description", source),
        last_edited=_text_field(data, "last_edited", source),
        hostname=_text_field(data, "hostname", source),
        extra={k: v for k, v in data.items() if k not in _KNOWN_TOP},
    )


def parse_animation_text(text: str | bytes, source: str = "<animation>") -> Animation:
    """Parses JSON text; syntax errors name the line and column."""
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise AnimationError(source, f"invalid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}") from exc
    except UnicodeDecodeError as exc:
        raise AnimationError(source, f"not UTF-8 text: {exc}") from exc
    except RecursionError as exc:
        raise AnimationError(source, "invalid JSON: nested too deeply") from exc
    return parse_animation(data, source)


def load_animation(path: str | Path) -> Animation:
    """Reads one animation file; every problem is an AnimationError naming the file."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise AnimationError(path.name, f"cannot read file: {exc.strerror or exc}") from exc
    return parse_animation_text(raw, path.name)


# -- saving -------------------------------------------------------------------------------------------
def keyframe_to_dict(kf: Keyframe) -> dict[str, Any]:
    out: dict[str, Any] = dict(kf.extra)
    out.update({"duration": kf.duration, "goals": dict(kf.goals), "pause": kf.pause, "torque": dict(kf.torque)})
    if kf.name is not None:
        out["name"] = kf.name
    if kf.stabilization_functions:
        out["stabilization_functions"] = dict(kf.stabilization_functions)
    if kf.p:
        out["p"] = dict(kf.p)
    return out


def animation_to_dict(anim: Animation) -> dict[str, Any]:
    """The Bit-Bots JSON layout; author and last_edited are always written."""
    out: dict[str, Any] = dict(anim.extra)
    out.update({
        "name": anim.name,
        "version": anim.version,
        "author": anim.author,
        "description": anim.description,
        "last_edited": anim.last_edited,
        "keyframes": [keyframe_to_dict(kf) for kf in anim.keyframes],
    })
    if anim.hostname:
        out["hostname"] = anim.hostname
    return out


def save_animation(anim: Animation, path: str | Path, *, touch: bool = True) -> Path:
    """Writes the file as the Bit-Bots recorder does (sorted keys, indent 4); touch stamps last_edited now.

    Written to a temporary file first and renamed, so a crash never leaves half a file.
    """
    path = Path(path)
    if touch:
        anim.last_edited = datetime.datetime.now().strftime(LAST_EDITED_FORMAT)
    text = json.dumps(animation_to_dict(anim), indent=4, sort_keys=True, allow_nan=False) + "\n"
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)
    return path


# -- checks against a robot ---------------------------------------------------------------------------
def check_joints(anim: Animation, joint_names: Iterable[str], source: str | None = None) -> None:
    """AnimationError for the first goal of a joint the robot does not have."""
    known = set(joint_names)
    for i, kf in enumerate(anim.keyframes):
        for joint in kf.goals:
            if joint not in known:
                raise AnimationError(source or anim.name, f"unknown joint {joint!r} (not a joint of this robot)",
                                     i, kf.name)


@dataclass
class ValidationReport:
    """Errors make the animation unplayable on this robot; warnings are worth a look in the editor; goals outside
    the joint limits are warnings here and listed again in out_of_limits, which the lab refuses to save or play."""

    errors: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    out_of_limits: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.errors


def validate(
    anim: Animation,
    joint_limits: Mapping[str, tuple[float, float]] | None = None,
    joint_names: Iterable[str] | None = None,
    max_velocity: float | Mapping[str, float] | None = None,
    source: str | None = None,
) -> ValidationReport:
    """Checks an animation against a robot: joints it lacks (error), goals outside the joint
    limits and moves faster than the servo can go (warnings).

    joint_limits and max_velocity are in the URDF's units (rad, rad/s); the file is in degrees.
    The speed check uses the mean speed between two keyframes (|change| / duration); the first
    keyframe is skipped because it starts from whatever pose the robot is in.
    """
    report = ValidationReport()
    src = source or anim.name
    names = set(joint_names) if joint_names is not None else None

    def where(i: int, kf: Keyframe) -> str:
        return f"{src}: keyframe {i}" + (f" ({kf.name!r})" if kf.name else "")

    last: dict[str, tuple[float, float]] = {}  # joint -> (rad, time its last point is left)
    t = 0.0
    for i, kf in enumerate(anim.keyframes):
        t += kf.duration
        for joint, deg in kf.goals.items():
            if names is not None and joint not in names:
                report.errors.append(f"{where(i, kf)}: unknown joint {joint!r} (not a joint of this robot)")
                continue
            rad = math.radians(deg)
            if joint_limits is not None and joint in joint_limits:
                lo, hi = joint_limits[joint]
                if not lo - 1e-9 <= rad <= hi + 1e-9:
                    problem = (f"{where(i, kf)}: goal {deg:g} deg for joint {joint!r} is outside its limits "
                               f"[{math.degrees(lo):.1f}, {math.degrees(hi):.1f}] deg")
                    report.warnings.append(problem)
                    report.out_of_limits.append(problem)
            vmax = max_velocity.get(joint) if isinstance(max_velocity, Mapping) else max_velocity
            if vmax is not None and joint in last:
                change, span = abs(rad - last[joint][0]), t - last[joint][1]
                if change > 1e-9 and (span <= 1e-9 or change / span > vmax):
                    speed = "an instant jump" if span <= 1e-9 else f"{math.degrees(change / span):.0f} deg/s"
                    report.warnings.append(
                        f"{where(i, kf)}: joint {joint!r} needs {speed}, more than its servo's "
                        f"{math.degrees(vmax):.0f} deg/s")
            last[joint] = (rad, t + kf.pause)
        t += kf.pause
    return report
