"""Leg IK against yourdfpy's forward kinematics of the Minibot URDF, and the walk engine's logic without physics."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yourdfpy
from hypothesis import given, settings
from hypothesis import strategies as st

from robot_nodes.walking import KinematicsError, LegKinematics, Phase, WalkEngine, WalkParams
from robot_nodes.walking.kinematics import MINIBOT_URDF, rpy_matrix

KIN = LegKinematics.from_urdf()
URDF = yourdfpy.URDF.load(str(MINIBOT_URDF), load_meshes=False, build_scene_graph=True)
SOLE = {"L": "l_sole", "R": "r_sole"}

# canonical angles well inside the workspace: hip yaw, roll, pitch, knee bend, ankle pitch, ankle roll
canonical = st.tuples(st.floats(-0.5, 0.5), st.floats(-0.3, 0.3), st.floats(-1.0, 0.5), st.floats(0.15, 1.8),
                      st.floats(-0.8, 0.5), st.floats(-0.3, 0.3))


def urdf_sole(side: str, joints: np.ndarray) -> np.ndarray:
    leg = KIN.leg(side)
    URDF.update_cfg(dict(zip(leg.joint_names(), joints, strict=True)))
    return URDF.get_transform(SOLE[side], "base_link")


def test_lengths_and_signs_come_from_the_urdf() -> None:
    left, right = KIN.left, KIN.right
    assert left.thigh == pytest.approx(0.15) and left.shank == pytest.approx(0.15)
    assert left.hip == pytest.approx([0.0, 0.055, -0.035]) and right.hip == pytest.approx([0.0, -0.055, -0.035])
    # Wolfgang: pitch joints mirrored between the legs, knee straight at +-0.2618
    assert left.signs["HipPitch"] == -right.signs["HipPitch"]
    straight = left.to_joints(np.zeros(6))[3], right.to_joints(np.zeros(6))[3]
    assert straight == pytest.approx((0.2618, -0.2618))


@pytest.mark.parametrize("side", ["L", "R"])
@settings(max_examples=60, deadline=None)
@given(angles=canonical)
def test_ik_inverts_yourdfpy_forward_kinematics(side: str, angles: tuple[float, ...]) -> None:
    leg = KIN.leg(side)
    joints = leg.to_joints(np.array(angles))
    target = urdf_sole(side, joints)
    solved = leg.ik(target[:3, 3], target[:3, :3])
    np.testing.assert_allclose(solved, joints, atol=1e-7)
    again = urdf_sole(side, solved)
    np.testing.assert_allclose(again, target, atol=1e-9)


@pytest.mark.parametrize("side", ["L", "R"])
def test_own_fk_matches_yourdfpy(side: str) -> None:
    rng = np.random.default_rng(7)
    leg = KIN.leg(side)
    for _ in range(20):
        joints = leg.to_joints(rng.uniform([-0.5, -0.3, -1.0, 0.1, -0.8, -0.3], [0.5, 0.3, 0.5, 1.8, 0.5, 0.3]))
        position, rotation = leg.fk(joints)
        expected = urdf_sole(side, joints)
        np.testing.assert_allclose(position, expected[:3, 3], atol=1e-12)
        np.testing.assert_allclose(rotation, expected[:3, :3], atol=1e-12)


def test_walkready_pose_is_a_flat_foot_under_the_hip() -> None:
    """The walkready animation's leg (degrees) puts the sole flat, straight below the hip."""
    joints = np.radians([0.0, 0.0, 20.05, 55.1, -20.05, 0.0])
    position, rotation = KIN.left.fk(joints)
    np.testing.assert_allclose(rotation, np.eye(3), atol=1e-5)
    assert position[1] == pytest.approx(0.06) and -0.37 < position[2] < -0.34
    np.testing.assert_allclose(KIN.left.ik(position, rotation), joints, atol=1e-6)


def test_unreachable_target_gives_a_stretched_leg_not_nan() -> None:
    q = KIN.left.ik(np.array([0.0, 0.06, -1.0]), rpy_matrix(0.0, 0.0, 0.0))
    assert np.all(np.isfinite(q))
    assert q[3] == pytest.approx(0.2618, abs=1e-6)  # knee straight


def test_a_urdf_without_legs_is_refused_clearly(tmp_path: Path) -> None:
    bad = tmp_path / "arm.urdf"
    bad.write_text('<robot name="arm"><link name="base_link"/></robot>')
    with pytest.raises(KinematicsError, match="no joint LHipYaw"):
        LegKinematics.from_urdf(bad)
    with pytest.raises(KinematicsError, match="cannot read"):
        LegKinematics.from_urdf(tmp_path / "missing.urdf")


# -- the engine without physics ---------------------------------------------------------------------------
def run(engine: WalkEngine, seconds: float, dt: float = 0.01) -> list[Phase]:
    phases = []
    for _ in range(round(seconds / dt)):
        engine.update(dt)
        phases.append(engine.phase)
    return phases


def test_engine_idles_without_command_and_walks_with_one() -> None:
    engine = WalkEngine()
    assert set(run(engine, 1.0)) == {Phase.IDLE}
    engine.set_command(0.1, 0.0, 0.0)
    phases = run(engine, 3.0)
    assert Phase.STARTING in phases and phases[-1] is Phase.WALKING and engine.steps >= 4
    assert engine.velocity.x == pytest.approx(0.1)
    engine.set_command(0.0, 0.0, 0.0)
    phases = run(engine, 3.0)
    assert Phase.STOPPING in phases and phases[-1] is Phase.IDLE
    stance = engine.stance_goals()
    out = engine.update(0.01)
    np.testing.assert_allclose(out.positions, [stance[n] for n in out.names], atol=1e-9)


def test_stop_request_ends_walking_even_with_a_command() -> None:
    engine = WalkEngine()
    engine.set_command(0.1, 0.05, 0.2)
    run(engine, 2.0)
    engine.request_stop(True)
    assert run(engine, 3.0)[-1] is Phase.IDLE
    engine.request_stop(False)
    assert run(engine, 1.0)[-1] in (Phase.STARTING, Phase.WALKING)


def test_commands_are_limited_and_non_finite_ones_ignored() -> None:
    params = WalkParams()
    engine = WalkEngine(params)
    engine.set_command(5.0, -5.0, math.nan)
    run(engine, 6.0)
    assert engine.velocity.x == pytest.approx(params.max_step_x * params.step_frequency)
    assert engine.velocity.y == pytest.approx(-params.max_step_y * params.step_frequency)
    assert engine.velocity.yaw == 0.0


def test_parameter_change_applies_at_the_next_step() -> None:
    params = WalkParams()
    engine = WalkEngine(params)
    engine.set_command(0.1, 0.0, 0.0)
    run(engine, 2.0)
    steps = engine.steps
    params.step_frequency = 2.5
    # within one step (0.5 s at 2 Hz) the engine runs at the new frequency
    t = 0.0
    while engine.steps == steps:
        engine.update(0.01)
        t += 0.01
    assert t <= 1.0 / 2.0 + 0.02
    start, t = engine.steps, 0.0
    while engine.steps == start:
        engine.update(0.001)
        t += 0.001
    assert t == pytest.approx(1.0 / 2.5, abs=0.005)


def test_feet_are_mirrored_in_the_walk_stance() -> None:
    goals = WalkEngine().stance_goals()
    for joint in ("HipPitch", "Knee", "AnklePitch"):
        assert goals["L" + joint] == pytest.approx(-goals["R" + joint], abs=1e-9)
    for joint in ("HipRoll", "AnkleRoll"):
        assert goals["L" + joint] == pytest.approx(-goals["R" + joint], abs=1e-9)


def test_standing_goals_are_solved_again_when_the_feet_or_the_gait_change() -> None:
    params = WalkParams()
    engine = WalkEngine(params)
    first = engine.update(0.01).positions
    np.testing.assert_allclose(first, engine._solve_legs(0.0), atol=1e-12)
    first[:] = 0.0  # what a caller does with its goals does not reach the kept ones
    np.testing.assert_allclose(engine.update(0.01).positions, engine._solve_legs(0.0), atol=1e-12)
    kept = engine.update(0.01).positions
    engine.feet["L"].pose.x += 0.02  # the feet where a stop left them
    moved = engine.update(0.01).positions
    np.testing.assert_allclose(moved, engine._solve_legs(0.0), atol=1e-12)
    assert np.abs(moved - kept).max() > 0.01
    params.trunk_height -= 0.02
    engine.stance_goals()  # takes the gait's new snapshot, feet home
    lower = engine.update(0.01).positions
    np.testing.assert_allclose(lower, engine._solve_legs(0.0), atol=1e-12)
    assert np.abs(lower - kept).max() > 0.01
