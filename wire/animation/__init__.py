"""pitchside animation node: Bit-Bots keyframe files, their editor operations and the spline player."""

from wire.animation.animation_file import (
    Animation,
    AnimationError,
    Keyframe,
    ValidationReport,
    check_joints,
    load_animation,
    parse_animation,
    parse_animation_text,
    save_animation,
    validate,
)
from wire.animation.editing import (
    copy_side,
    delete_keyframe,
    duplicate_keyframe,
    insert_keyframe,
    invert,
    mirror,
    mirror_signs_from_axes,
    move_keyframe,
    partner,
    rename_joints,
)
from wire.animation.player import AnimationPlayer, JointCurve, TorqueChange

__all__ = [
    "Animation",
    "AnimationError",
    "AnimationPlayer",
    "JointCurve",
    "Keyframe",
    "TorqueChange",
    "ValidationReport",
    "check_joints",
    "copy_side",
    "delete_keyframe",
    "duplicate_keyframe",
    "insert_keyframe",
    "invert",
    "load_animation",
    "mirror",
    "mirror_signs_from_axes",
    "move_keyframe",
    "parse_animation",
    "parse_animation_text",
    "partner",
    "rename_joints",
    "save_animation",
    "validate",
]
