"""The Bit-Bots animation file: real files load, round trips keep every field, bad files get precise errors."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wire.animation import (
    Animation,
    AnimationError,
    Keyframe,
    copy_side,
    delete_keyframe,
    duplicate_keyframe,
    insert_keyframe,
    invert,
    load_animation,
    mirror,
    mirror_signs_from_axes,
    move_keyframe,
    parse_animation,
    parse_animation_text,
    partner,
    rename_joints,
    save_animation,
    validate,
)
from wire.animation.animation_file import check_joints
from wire.animation.editing import default_mirror_sign

WOLFGANG_JOINTS = [
    "HeadPan", "HeadTilt", "LShoulderPitch", "LShoulderRoll", "LElbow", "RShoulderPitch", "RShoulderRoll", "RElbow",
    "LHipYaw", "LHipRoll", "LHipPitch", "LKnee", "LAnklePitch", "LAnkleRoll", "RHipYaw", "RHipRoll", "RHipPitch",
    "RKnee", "RAnklePitch", "RAnkleRoll",
]


def animation_files(testdata: Path) -> list[Path]:
    files = sorted((testdata / "animations").glob("*.json"))
    assert len(files) >= 5
    return files


def test_every_real_file_loads(testdata: Path) -> None:
    for path in animation_files(testdata):
        anim = load_animation(path)
        raw = json.loads(path.read_text())
        assert anim.name == raw["name"]
        assert len(anim.keyframes) == len(raw["keyframes"]) >= 1
        for kf, raw_kf in zip(anim.keyframes, raw["keyframes"], strict=True):
            assert kf.goals == raw_kf["goals"]
            assert kf.duration == raw_kf.get("duration", 1.0)
            assert kf.pause == raw_kf.get("pause", 0.0)


def test_current_layout_fields(testdata: Path) -> None:
    anim = load_animation(testdata / "animations" / "wolfgang_stand_up_back.json")
    assert (anim.name, anim.author, anim.version) == ("stand_up_back", "Flo", "1.0")
    assert anim.last_edited == "2024-07-17 11:41:14.004363"
    assert [kf.name for kf in anim.keyframes] == ["bridge", "bridge_shift", "push", "squat"]
    assert anim.keyframes[0].pause == 0.5 and anim.keyframes[0].goals["LKnee"] == 124.0
    assert sorted(anim.joints) == sorted(WOLFGANG_JOINTS)
    assert anim.duration == pytest.approx(1.0 + 0.5 + 0.9 + 0.2 + 0.2 + 0.5)


def test_legacy_layout_keeps_interpolator_keys(testdata: Path, tmp_path: Path) -> None:
    anim = load_animation(testdata / "animations" / "wolfgang_init.json")
    assert anim.name == "init" and anim.author == "" and anim.keyframes[0].name is None
    assert anim.extra == {"default_interpolator": "CatmullRomInterpolator"}
    save_animation(anim, tmp_path / "init.json", touch=False)
    again = json.loads((tmp_path / "init.json").read_text())
    assert again["default_interpolator"] == "CatmullRomInterpolator"


def test_piplus_names(testdata: Path) -> None:
    anim = load_animation(testdata / "animations" / "piplus_walkready.json")
    assert len(anim.joints) == 22 and "l_calf_joint" in anim.joints
    report = validate(anim, joint_names=WOLFGANG_JOINTS)
    assert not report.ok and any("'l_calf_joint'" in e for e in report.errors)
    mapping = {"l_calf_joint": "LKnee", "r_calf_joint": "RKnee", "l_hip_pitch_joint": "LHipPitch",
               "r_hip_pitch_joint": "RHipPitch"}
    renamed = rename_joints(anim, mapping)
    assert renamed.keyframes[0].goals["LKnee"] == -68.75 and "l_calf_joint" not in renamed.joints
    assert "l_calf_joint" in anim.joints  # pure: the input is unchanged
    with pytest.raises(AnimationError, match="no new name for joint"):
        rename_joints(anim, mapping, strict=True)
    with pytest.raises(AnimationError, match="two joints map to 'LKnee'"):
        rename_joints(anim, {"l_calf_joint": "LKnee", "r_calf_joint": "LKnee"})


def test_round_trip_keeps_every_field(testdata: Path, tmp_path: Path) -> None:
    for path in animation_files(testdata):
        anim = load_animation(path)
        out = save_animation(anim, tmp_path / path.name, touch=False)
        assert load_animation(out) == anim, path.name
    full = Animation(
        name="wave", version="2", author="pitchside", description="a wave", last_edited="2026-01-01 10:00:00.000000",
        hostname="lab-pc", extra={"interpolators": {"LElbow": "Linear"}, "future_key": [1, 2]},
        keyframes=[Keyframe(goals={"LElbow": 10.5}, duration=0.4, pause=0.1, torque={"LElbow": 1.0},
                            stabilization_functions={"LAnkleRoll": "0.5*imu_roll"}, name="up", p={"LElbow": 32.0},
                            extra={"comment": "x"}),
                   Keyframe(goals={}, duration=0.0)])
    path = save_animation(full, tmp_path / "wave.json", touch=False)
    assert load_animation(path) == full


def test_save_writes_author_and_last_edited(tmp_path: Path) -> None:
    anim = parse_animation({"name": "nod", "keyframes": [{"goals": {"HeadTilt": -30}}]})
    save_animation(anim, tmp_path / "nod.json")
    raw = json.loads((tmp_path / "nod.json").read_text())
    assert raw["author"] == "" and len(raw["last_edited"]) == len("2024-07-17 11:41:14.004363")
    assert raw["keyframes"][0] == {"duration": 1.0, "goals": {"HeadTilt": -30.0}, "pause": 0.0, "torque": {}}
    assert not list(tmp_path.glob(".*.tmp"))


@pytest.mark.parametrize(("text", "expected"), [
    ('{"name": "a", "keyframes": [}', "bad.json: invalid JSON at line 1, column 29: Expecting value"),
    ('{"keyframes": []}', "bad.json: missing 'name'"),
    ('{"name": "", "keyframes": []}', "bad.json: 'name' must be a non-empty string"),
    ('[1, 2]', "bad.json: the file must hold one JSON object, got list"),
    ('{"name": "a", "keyframes": {"duration": 1}}', "bad.json: 'keyframes' must be a list, got dict"),
    ('{"name": "a", "keyframes": [{"duration": -1}]}', "bad.json: keyframe 0: duration must be a finite number >= 0"),
    ('{"name": "a", "keyframes": [{"duration": NaN}]}', "bad.json: keyframe 0: duration must be a finite number"),
    ('{"name": "a", "keyframes": [{}, {"pause": "long", "name": "p"}]}',
     "bad.json: keyframe 1 ('p'): pause is not a number: 'long'"),
    ('{"name": "a", "keyframes": [{}, {}, {}, {"name": "lift_foot", "goals": {"LKnee": "abc"}}]}',
     "bad.json: keyframe 3 ('lift_foot'): goal for joint 'LKnee' is not a number: 'abc'"),
    ('{"name": "a", "keyframes": [{"goals": {"LKnee": true}}]}', "keyframe 0: goal for joint 'LKnee' is not a number"),
    ('{"name": "a", "keyframes": [{"goals": [1]}]}', "keyframe 0: goals must be an object"),
    ('{"name": "a", "keyframes": [{"torque": {"LKnee": "on"}}]}', "keyframe 0: torque for joint 'LKnee'"),
    ('{"name": "a", "keyframes": [5]}', "bad.json: keyframe 0: a keyframe must be an object, got int"),
])
def test_malformed_files_name_file_keyframe_and_problem(tmp_path: Path, text: str, expected: str) -> None:
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(AnimationError) as info:
        load_animation(path)
    assert expected in str(info.value)
    assert info.value.source == "bad.json"


def test_missing_and_binary_files(tmp_path: Path) -> None:
    with pytest.raises(AnimationError, match=r"nothing\.json: cannot read file"):
        load_animation(tmp_path / "nothing.json")
    (tmp_path / "bin.json").write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(AnimationError, match=r"bin\.json: "):
        load_animation(tmp_path / "bin.json")


def test_unknown_joints_and_limits_and_speed(testdata: Path) -> None:
    anim = load_animation(testdata / "animations" / "wolfgang_stand_up_front.json")
    check_joints(anim, WOLFGANG_JOINTS, "stand_up_front.json")
    with pytest.raises(AnimationError) as info:
        check_joints(anim, [j for j in WOLFGANG_JOINTS if j != "LKnee"], "stand_up_front.json")
    assert str(info.value) == ("stand_up_front.json: keyframe 0 ('arms_down'): unknown joint 'LKnee' "
                               "(not a joint of this robot)")
    limits = {"LKnee": (-0.2, 2.8), "LHipPitch": (-0.79, 1.5)}
    report = validate(anim, limits, WOLFGANG_JOINTS, source="stand_up_front.json")
    assert report.ok
    assert any("keyframe 0 ('arms_down'): goal 115 deg for joint 'LHipPitch' is outside" in w
               for w in report.warnings)
    assert not any("LKnee" in w for w in report.warnings)
    # keyframe 1: LElbow 45 -> -70 deg in 0.3 s = 383 deg/s
    slow = validate(anim, max_velocity=math.radians(300))
    assert any("keyframe 1 ('extend_arms'): joint 'LElbow' needs 383 deg/s" in w for w in slow.warnings)
    assert not validate(anim, max_velocity=math.radians(400)).warnings


def test_mirror_rule_matches_wolfgang_urdf(testdata: Path) -> None:
    """The default signs equal the ones computed from the real URDF's joint axes."""
    yourdfpy = pytest.importorskip("yourdfpy")
    urdf = yourdfpy.URDF.load(str(testdata / "robots" / "wolfgang" / "urdf" / "robot.urdf"), load_meshes=False,
                              build_scene_graph=True)
    axes = {}
    for joint in urdf.robot.joints:
        if joint.type == "revolute":
            rotation = urdf.get_transform(joint.child, urdf.base_link)[:3, :3]
            axes[joint.name] = rotation @ np.asarray(joint.axis, dtype=float)
    signs = mirror_signs_from_axes(axes)
    assert set(signs) == set(WOLFGANG_JOINTS)
    assert signs == {j: default_mirror_sign(j) for j in WOLFGANG_JOINTS}
    assert signs["HeadPan"] == -1.0 and signs["HeadTilt"] == 1.0 and signs["LKnee"] == -1.0


def test_mirror_swaps_sides(testdata: Path) -> None:
    anim = load_animation(testdata / "animations" / "wolfgang_stand_up_front.json")
    kf = anim.keyframes[1]
    assert (kf.goals["LKnee"], kf.goals["RKnee"]) == (154.0, -154.0)
    # a symmetric real pose stays the same
    mirrored = mirror(anim)
    assert mirrored.keyframes[1].goals == pytest.approx(kf.goals)
    # an asymmetric pose: a left-arm-only motion becomes the same motion of the right arm
    wave = Animation("wave", [Keyframe(goals={"LShoulderPitch": 120.0, "LShoulderRoll": -20.0, "HeadPan": 30.0,
                                              "HeadTilt": 10.0}, torque={"LElbow": 0.0}, name="up")])
    right = mirror(wave).keyframes[0]
    assert right.goals == {"RShoulderPitch": -120.0, "RShoulderRoll": 20.0, "HeadPan": -30.0, "HeadTilt": 10.0}
    assert right.torque == {"RElbow": 0.0} and right.name == "up"
    assert mirror(mirror(wave)) == wave
    assert wave.keyframes[0].goals["LShoulderPitch"] == 120.0  # pure
    assert partner("l_calf_joint") == "r_calf_joint" and partner("HeadPan") is None
    only_second = mirror(anim, keyframes=[2])
    assert only_second.keyframes[0] == anim.keyframes[0]
    with pytest.raises(IndexError):
        mirror(anim, keyframes=[7])


def test_copy_side_makes_symmetric_pose() -> None:
    anim = Animation("a", [Keyframe(goals={"LKnee": 60.0, "RKnee": -10.0, "HeadPan": 5.0, "LHipYaw": 3.0})])
    sym = copy_side(anim, "left").keyframes[0].goals
    assert sym == {"LKnee": 60.0, "RKnee": -60.0, "HeadPan": 5.0, "LHipYaw": 3.0, "RHipYaw": -3.0}
    assert copy_side(anim, "right").keyframes[0].goals["LKnee"] == 10.0
    assert mirror(Animation("s", [Keyframe(goals=sym)])).keyframes[0].goals == {**sym, "HeadPan": -5.0}


def test_invert_plays_backwards() -> None:
    anim = Animation("a", [Keyframe({"J": 10.0}, duration=1.0, pause=0.5, name="k0"),
                           Keyframe({"J": 20.0}, duration=2.0, pause=0.0, name="k1"),
                           Keyframe({"J": 30.0}, duration=3.0, pause=0.25, name="k2")])
    back = invert(anim)
    assert [kf.name for kf in back.keyframes] == ["k2", "k1", "k0"]
    assert [kf.duration for kf in back.keyframes] == [1.0, 3.0, 2.0]
    assert [kf.pause for kf in back.keyframes] == [0.25, 0.0, 0.5]
    assert invert(back) == anim
    assert anim.keyframes[0].name == "k0"


def test_keyframe_list_edits() -> None:
    anim = Animation("a", [Keyframe({"J": float(i)}, name=f"k{i}") for i in range(3)])

    def names(a: Animation) -> list[str | None]:
        return [kf.name for kf in a.keyframes]

    assert names(insert_keyframe(anim, 1, Keyframe(name="new"))) == ["k0", "new", "k1", "k2"]
    assert names(insert_keyframe(anim, 3, Keyframe(name="end"))) == ["k0", "k1", "k2", "end"]
    dup = duplicate_keyframe(anim, 0)
    assert names(dup) == ["k0", "k0", "k1", "k2"] and dup.keyframes[0] is not dup.keyframes[1]
    assert names(delete_keyframe(anim, 1)) == ["k0", "k2"]
    assert names(move_keyframe(anim, 0, 2)) == ["k1", "k2", "k0"]
    assert names(move_keyframe(anim, 2, 0)) == ["k2", "k0", "k1"]
    assert names(anim) == ["k0", "k1", "k2"]
    for bad in (lambda: delete_keyframe(anim, 3), lambda: insert_keyframe(anim, 5, Keyframe()),
                lambda: move_keyframe(anim, 0, -1)):
        with pytest.raises(IndexError, match="out of range"):
            bad()


def test_parse_text_source_name() -> None:
    with pytest.raises(AnimationError, match=r"^editor: invalid JSON at line 2, column 1"):
        parse_animation_text('{"name": "a",\n}', source="editor")


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=8),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=8), children, max_size=4),
    max_leaves=20,
)
keyframe_like = st.fixed_dictionaries({}, optional={
    "goals": st.dictionaries(st.sampled_from(["LKnee", "RKnee", "HeadPan"]), json_values, max_size=3),
    "duration": json_values, "pause": json_values, "torque": json_values, "name": json_values,
    "stabilization_functions": json_values, "p": json_values})


@settings(max_examples=300, deadline=None)
@given(st.fixed_dictionaries({}, optional={"name": st.text(max_size=5) | json_values,
                                           "keyframes": st.lists(keyframe_like, max_size=4) | json_values,
                                           "version": json_values, "author": json_values}))
def test_fuzz_structured_input_gives_animation_or_animation_error(data: dict[str, object]) -> None:
    try:
        anim = parse_animation(data, source="fuzz.json")
    except AnimationError as exc:
        assert str(exc).startswith("fuzz.json: ")
        return
    assert isinstance(anim.name, str) and all(math.isfinite(kf.duration) for kf in anim.keyframes)


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=200) | st.text(max_size=200).map(str.encode))
def test_fuzz_bytes_give_animation_or_animation_error(raw: bytes) -> None:
    try:
        anim = parse_animation_text(raw, source="fuzz.json")
    except AnimationError as exc:
        assert str(exc).startswith("fuzz.json: ")
        return
    assert isinstance(anim, Animation)


def test_pathological_json() -> None:
    for text in ("[" * 100000 + "]" * 100000, '{"name": "a", "keyframes": [{"duration": 1e999}]}',
                 '{"name": "a", "keyframes": [{"goals": {"J": ' + "9" * 400 + "}}]}"):
        with pytest.raises(AnimationError):
            parse_animation_text(text, source="x.json")
