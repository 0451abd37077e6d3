"""The keyframe player: curves through the keyframes at the right times, holds, no overshoot, torque timing."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wire.animation import Animation, AnimationPlayer, JointCurve, Keyframe, load_animation


def nod() -> Animation:
    return Animation("nod", [
        Keyframe({"HeadTilt": -30.0}, duration=0.5, pause=0.2, name="down"),
        Keyframe({"HeadTilt": 0.0, "HeadPan": 20.0}, duration=0.5, torque={"HeadPan": 1.0}, name="up"),
        Keyframe({"HeadTilt": 10.0}, duration=0.3, pause=0.4, torque={"HeadTilt": 0.0, "HeadPan": 0.0}),
    ])


def test_timing_and_duration() -> None:
    player = AnimationPlayer(nod(), {"HeadTilt": 0.0, "HeadPan": 0.0})
    assert player.keyframe_times == pytest.approx([0.5, 1.2, 1.5])
    assert player.duration == pytest.approx(1.9)
    assert player.joint_names == ["HeadTilt", "HeadPan"]
    assert player.percent_done(0.0) == 0.0
    assert player.percent_done(0.95) == pytest.approx(50.0)
    assert player.percent_done(5.0) == 100.0 and player.finished(1.9) and not player.finished(1.8)
    empty = AnimationPlayer(Animation("e", []))
    assert empty.duration == 0.0 and empty.percent_done(0.0) == 100.0


@pytest.mark.parametrize("interpolation", ["spline", "linear"])
def test_passes_through_keyframes_and_holds_during_pause(interpolation: str) -> None:
    player = AnimationPlayer(nod(), {"HeadTilt": math.radians(12.0), "HeadPan": 0.0}, interpolation)
    tilt = player.curves["HeadTilt"]
    assert tilt(0.0) == pytest.approx(12.0)  # starts at the measured pose (rad in, degrees on the curve)
    assert tilt(0.5) == pytest.approx(-30.0)
    for t in np.linspace(0.5, 0.7, 9):  # the pause of "down"
        assert tilt(float(t)) == pytest.approx(-30.0)
    assert tilt(1.2) == pytest.approx(0.0)
    for t in np.linspace(1.5, 1.9, 9):
        assert tilt(float(t)) == pytest.approx(10.0)
    assert tilt(10.0) == pytest.approx(10.0)
    pan = player.curves["HeadPan"]  # only in keyframe 1: a straight path from the start to t=1.2
    assert pan(1.2) == pytest.approx(20.0) and 0.0 < pan(0.6) < 20.0 and pan(1.9) == pytest.approx(20.0)
    assert player.positions(0.5)[0] == pytest.approx(math.radians(-30.0))
    assert player.goals_at(1.2) == pytest.approx({"HeadTilt": 0.0, "HeadPan": math.radians(20.0)})


def test_linear_is_straight_and_spline_is_smooth() -> None:
    linear = AnimationPlayer(nod(), {"HeadTilt": 0.0}, "linear").curves["HeadTilt"]
    assert linear(0.25) == pytest.approx(-15.0)
    spline = AnimationPlayer(nod(), {"HeadTilt": 0.0}, "spline").curves["HeadTilt"]
    assert spline(0.25) == pytest.approx(-15.0)  # symmetric ease-in-out from rest to rest
    assert abs(spline(0.05)) < abs(linear(0.05))  # starts from rest, not with a jump in velocity
    h = 1e-4  # the velocity is continuous at an interior keyframe (C1)
    c = JointCurve.through([0.0, 1.0, 2.0, 3.0], [0.0, 10.0, 30.0, 35.0])
    left = (c(1.0) - c(1.0 - h)) / h
    right = (c(1.0 + h) - c(1.0)) / h
    assert left == pytest.approx(right, rel=1e-2) and left > 10.0
    with pytest.raises(ValueError, match="interpolation"):
        JointCurve.through([0.0, 1.0], [0.0, 1.0], "cubic")


def test_missing_start_position_starts_at_first_goal() -> None:
    player = AnimationPlayer(nod(), {})
    assert player.curves["HeadTilt"](0.0) == pytest.approx(-30.0)
    assert player.curves["HeadPan"](0.3) == pytest.approx(20.0)


def test_zero_duration_jumps() -> None:
    anim = Animation("jump", [Keyframe({"J": 40.0}, duration=0.0), Keyframe({"J": 50.0}, duration=1.0)])
    player = AnimationPlayer(anim, {"J": 0.0})
    assert player.curves["J"](0.0) == pytest.approx(40.0) and player.curves["J"](1.0) == pytest.approx(50.0)


def test_torque_changes_apply_at_end_of_pause() -> None:
    player = AnimationPlayer(nod(), {})
    assert [(c.time, c.keyframe) for c in player.torque_changes] == [(pytest.approx(1.2), 1), (pytest.approx(1.9), 2)]
    assert player.torque_at(1.1) == {}
    assert player.torque_at(1.2) == {"HeadPan": 1.0}
    assert player.torque_at(1.6) == {"HeadPan": 1.0}
    assert player.torque_at(1.9) == {"HeadPan": 0.0, "HeadTilt": 0.0}


times_and_values = st.lists(
    st.tuples(st.floats(0.01, 2.0), st.floats(0.0, 1.0), st.floats(-180.0, 180.0)), min_size=1, max_size=8)


@settings(max_examples=200, deadline=None)
@given(times_and_values, st.floats(-180.0, 180.0))
def test_no_overshoot_beyond_neighbouring_keyframes(frames: list[tuple[float, float, float]], start: float) -> None:
    anim = Animation("h", [Keyframe({"J": v}, duration=d, pause=p) for d, p, v in frames])
    player = AnimationPlayer(anim, {"J": math.radians(start)})
    curve = player.curves["J"]
    t_points, y_points = curve.times, curve.values
    for k in range(len(t_points) - 1):
        lo, hi = sorted((y_points[k], y_points[k + 1]))
        for s in np.linspace(t_points[k], t_points[k + 1], 17):
            y = curve(float(s))
            assert lo - 1e-9 <= y <= hi + 1e-9
    for t, y in zip(t_points, y_points, strict=True):
        assert curve(float(t)) == pytest.approx(y)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(0.0, 50.0), min_size=2, max_size=10))
def test_monotone_data_gives_monotone_curve(steps: list[float]) -> None:
    values = list(np.cumsum(steps))
    curve = JointCurve.through([float(i) for i in range(len(values))], values)
    samples = [curve(float(t)) for t in np.linspace(0, len(values) - 1, 200)]
    assert all(b >= a - 1e-9 for a, b in itertools.pairwise(samples))


def test_real_stand_up_ends_at_last_keyframe(testdata: Path) -> None:
    anim = load_animation(testdata / "animations" / "wolfgang_stand_up_back.json")
    start = dict.fromkeys(anim.joints, 0.0)
    player = AnimationPlayer(anim, start)
    assert player.duration == pytest.approx(3.3)
    last = anim.keyframes[-1].goals
    assert player.goals_at(player.duration) == pytest.approx({j: math.radians(v) for j, v in last.items()})
    bridge = anim.keyframes[0].goals
    for t in (1.0, 1.25, 1.5):  # the 0.5 s pause after "bridge"
        assert player.goals_at(t) == pytest.approx({j: math.radians(v) for j, v in bridge.items()})
