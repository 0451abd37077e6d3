"""Animation editor operations (rename joints, mirror sides, play backwards, keyframe list edits), all pure.

Every function returns a new Animation and leaves its input untouched, so the editor can keep
the old one for undo.

Mirror rule (checked against the Wolfgang URDF in tests/test_animation_file.py): reflecting a
motion through the robot's sagittal plane maps a rotation by theta about a joint axis ``a`` to a
rotation by -theta about the reflected axis ``R a`` (R = diag(1, -1, 1), x forward, y left).

* Paired joints (``L``/``R`` prefix as in ``LKnee``, or ``l_``/``r_``, ``left_``/``right_``): the
  value moves to the partner joint, multiplied by ``-dot(R a_left, a_right)``. In Bit-Bots'
  Wolfgang URDF the right-side axes are the mirror images of the left ones for *every* pair
  (pitch, roll and yaw), so the sign is -1 for all of them: that is why a symmetric pose has
  ``LKnee +160, RKnee -160`` and ``LAnkleRoll 4, RAnkleRoll -4``. The PiPlus files follow the same
  convention (``l_hip_pitch_joint -34.38``, ``r_hip_pitch_joint 34.38``).
* Centre joints: the value is multiplied by ``-dot(R a, a)``: yaw and roll joints (``HeadPan``,
  names with ``yaw``, ``pan`` or ``roll``) change sign, pitch joints (``HeadTilt``) keep it.

A robot with other axis conventions passes its own signs, e.g. from ``mirror_signs_from_axes``.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Iterable, Mapping, Sequence

from wire.animation.animation_file import Animation, AnimationError, Keyframe

_SIDE_PATTERNS = (
    (re.compile(r"^L(?=[A-Z])"), "L", "R"),
    (re.compile(r"^R(?=[A-Z])"), "R", "L"),
    (re.compile(r"^l_"), "l_", "r_"),
    (re.compile(r"^r_"), "r_", "l_"),
    (re.compile(r"^left_"), "left_", "right_"),
    (re.compile(r"^right_"), "right_", "left_"),
)
_SIGN_FLIPPING_CENTRE = re.compile(r"yaw|pan|roll", re.IGNORECASE)


def side_of(joint: str) -> str | None:
    """'left', 'right' or None (a centre joint such as HeadPan)."""
    for pattern, prefix, _ in _SIDE_PATTERNS:
        if pattern.match(joint):
            return "left" if prefix.lower().startswith("l") else "right"
    return None


def partner(joint: str) -> str | None:
    """The same joint on the other side (LKnee -> RKnee, l_calf_joint -> r_calf_joint), None for centre joints."""
    for pattern, prefix, other in _SIDE_PATTERNS:
        if pattern.match(joint):
            return other + joint[len(prefix):]
    return None


def default_mirror_sign(joint: str) -> float:
    """Bit-Bots convention (see module doc): -1 for paired joints, -1 for centre yaw/roll, +1 for centre pitch."""
    if partner(joint) is not None:
        return -1.0
    return -1.0 if _SIGN_FLIPPING_CENTRE.search(joint) else 1.0


def mirror_signs_from_axes(axes: Mapping[str, Sequence[float]]) -> dict[str, float]:
    """Mirror signs from joint axes in the robot's base frame at the zero pose (x forward, y left, z up).

    For a paired joint the sign multiplies its value when it moves to the partner; for a centre
    joint it multiplies the joint's own value.
    """
    def reflect(a: Sequence[float]) -> tuple[float, float, float]:
        return (float(a[0]), -float(a[1]), float(a[2]))

    def dot(a: Sequence[float], b: Sequence[float]) -> float:
        return float(a[0]) * float(b[0]) + float(a[1]) * float(b[1]) + float(a[2]) * float(b[2])

    signs = {}
    for joint, axis in axes.items():
        other = partner(joint)
        target = axes.get(other) if other is not None else axis
        if target is None:
            continue
        signs[joint] = -1.0 if dot(reflect(axis), target) > 0 else 1.0
    return signs


def _pick(anim: Animation, keyframes: Iterable[int] | None) -> set[int]:
    chosen = set(range(len(anim.keyframes))) if keyframes is None else set(keyframes)
    for i in chosen:
        if not 0 <= i < len(anim.keyframes):
            raise IndexError(f"{anim.name}: no keyframe {i} (it has {len(anim.keyframes)})")
    return chosen


def _sign(joint: str, signs: Mapping[str, float] | None) -> float:
    if signs is not None and joint in signs:
        return signs[joint]
    return default_mirror_sign(joint)


def _swap_names(table: Mapping[str, object]) -> dict[str, object]:
    return {partner(j) or j: v for j, v in table.items()}


def mirror_keyframe(kf: Keyframe, signs: Mapping[str, float] | None = None) -> Keyframe:
    """The keyframe's motion done by the other side (a left kick becomes a right kick)."""
    out = copy.deepcopy(kf)
    out.goals = {partner(j) or j: _sign(j, signs) * v for j, v in kf.goals.items()}
    out.torque = dict(_swap_names(kf.torque))  # type: ignore[arg-type]
    out.p = dict(_swap_names(kf.p))  # type: ignore[arg-type]
    out.stabilization_functions = dict(_swap_names(kf.stabilization_functions))  # type: ignore[arg-type]
    return out


def mirror(anim: Animation, signs: Mapping[str, float] | None = None,
           keyframes: Iterable[int] | None = None) -> Animation:
    """Swaps left and right (sign rule in the module doc) in the chosen keyframes (default all).

    Bit-Bots' recording tool calls this per-frame operation "invert frame".
    """
    chosen = _pick(anim, keyframes)
    out = copy.deepcopy(anim)
    out.keyframes = [mirror_keyframe(kf, signs) if i in chosen else copy.deepcopy(kf)
                     for i, kf in enumerate(anim.keyframes)]
    return out


def copy_side(anim: Animation, source: str = "left", signs: Mapping[str, float] | None = None,
              keyframes: Iterable[int] | None = None) -> Animation:
    """Makes poses symmetric: the source side's goals, mirrored, overwrite the other side's.

    Bit-Bots' recording tool calls this "mirror frame"; centre joints are left as they are.
    """
    if source not in ("left", "right"):
        raise ValueError(f"source must be 'left' or 'right', got {source!r}")
    chosen = _pick(anim, keyframes)
    out = copy.deepcopy(anim)
    for i in chosen:
        kf = out.keyframes[i]
        for joint, value in list(kf.goals.items()):
            other = partner(joint)
            if other is not None and side_of(joint) == source:
                kf.goals[other] = _sign(joint, signs) * value
        for table in (kf.torque, kf.p):
            for joint, value in list(table.items()):
                other = partner(joint)
                if other is not None and side_of(joint) == source:
                    table[other] = value
    return out


def invert(anim: Animation) -> Animation:
    """The animation played backwards (e.g. a sit-down from a stand-up).

    The poses come in reverse order; the move into pose k takes the time the forward animation
    took to leave it, pauses stay with their pose, and the first move (from wherever the robot
    is) keeps the forward animation's first duration.
    """
    out = copy.deepcopy(anim)
    frames = list(reversed(copy.deepcopy(anim.keyframes)))
    forward = anim.keyframes
    n = len(forward)
    for j, kf in enumerate(frames):
        # frames[j] is forward[n-1-j]; it is reached by undoing the move forward[n-j] made.
        kf.duration = forward[0].duration if j == 0 else forward[n - j].duration
    out.keyframes = frames
    return out


def rename_joints(anim: Animation, mapping: Mapping[str, str], strict: bool = False) -> Animation:
    """Joint names mapped (e.g. PiPlus names to another robot's); unmapped names stay unless strict."""
    def rename(table: Mapping[str, object], i: int, kf: Keyframe) -> dict[str, object]:
        out: dict[str, object] = {}
        for joint, value in table.items():
            if joint not in mapping and strict:
                raise AnimationError(anim.name, f"no new name for joint {joint!r}", i, kf.name)
            new = mapping.get(joint, joint)
            if new in out:
                raise AnimationError(anim.name, f"two joints map to {new!r}", i, kf.name)
            out[new] = value
        return out

    result = copy.deepcopy(anim)
    for i, kf in enumerate(result.keyframes):
        kf.goals = rename(kf.goals, i, kf)  # type: ignore[assignment]
        kf.torque = rename(kf.torque, i, kf)  # type: ignore[assignment]
        kf.p = rename(kf.p, i, kf)  # type: ignore[assignment]
        kf.stabilization_functions = rename(kf.stabilization_functions, i, kf)  # type: ignore[assignment]
    return result


# -- keyframe list edits ------------------------------------------------------------------------------
def _check_index(anim: Animation, index: int, allow_end: bool = False) -> None:
    top = len(anim.keyframes) + (1 if allow_end else 0)
    if not 0 <= index < top:
        raise IndexError(f"{anim.name}: keyframe index {index} out of range 0..{top - 1}")


def insert_keyframe(anim: Animation, index: int, keyframe: Keyframe) -> Animation:
    """keyframe inserted before position index (index == len appends)."""
    _check_index(anim, index, allow_end=True)
    out = copy.deepcopy(anim)
    out.keyframes.insert(index, copy.deepcopy(keyframe))
    return out


def duplicate_keyframe(anim: Animation, index: int) -> Animation:
    """A copy of keyframe index placed right after it."""
    _check_index(anim, index)
    return insert_keyframe(anim, index + 1, anim.keyframes[index])


def delete_keyframe(anim: Animation, index: int) -> Animation:
    _check_index(anim, index)
    out = copy.deepcopy(anim)
    del out.keyframes[index]
    return out


def move_keyframe(anim: Animation, index: int, new_index: int) -> Animation:
    """Keyframe index moved so that it ends up at new_index."""
    _check_index(anim, index)
    _check_index(anim, new_index)
    out = copy.deepcopy(anim)
    out.keyframes.insert(new_index, out.keyframes.pop(index))
    return out
