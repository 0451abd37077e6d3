"""The Minibot URDF: Wolfgang's joint conventions, plausible size and mass, and the MuJoCo model built from it."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import yourdfpy

from robot_nodes.sim import MINIBOT_URDF, STAND_POSE, SimWorld

JOINTS = ["HeadPan", "HeadTilt", "LShoulderPitch", "LShoulderRoll", "LElbow", "RShoulderPitch", "RShoulderRoll",
          "RElbow", "LHipYaw", "LHipRoll", "LHipPitch", "LKnee", "LAnklePitch", "LAnkleRoll", "RHipYaw", "RHipRoll",
          "RHipPitch", "RKnee", "RAnklePitch", "RAnkleRoll"]
ANIMATIONS = ["wolfgang_init.json", "wolfgang_stand_up_front.json", "wolfgang_stand_up_back.json",
              "wolfgang_falling_front.json"]


def _load(path: Path) -> yourdfpy.URDF:
    return yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=True, load_collision_meshes=False)


def _frames(urdf: yourdfpy.URDF, cfg: dict[str, float]) -> dict[str, np.ndarray]:
    """Every joint axis and the sole/camera orientations, in the torso frame."""
    urdf.update_cfg({n: cfg.get(n, 0.0) for n in urdf.actuated_joint_names})
    out = {}
    for name in urdf.actuated_joint_names:
        joint = urdf.joint_map[name]
        out[name] = urdf.get_transform(joint.child, "torso")[:3, :3] @ np.array(joint.axis)
    for link in ("l_sole", "r_sole", "camera"):
        out[link] = urdf.get_transform(link, "torso")[:3, :3]
    return out


def test_joint_names_are_the_bitbots_twenty() -> None:
    urdf = _load(MINIBOT_URDF)
    assert sorted(urdf.actuated_joint_names) == sorted(JOINTS)
    for link in ("base_link", "torso", "imu_frame", "camera", "camera_optical_frame", "l_sole", "r_sole"):
        assert link in urdf.link_map, link


def test_bitbots_animations_move_it_like_wolfgang(testdata: Path) -> None:
    """Same joint values -> same joint axes and foot/camera orientations as the real Wolfgang, keyframe by keyframe."""
    wolfgang = _load(testdata / "robots" / "wolfgang" / "urdf" / "robot.urdf")
    minibot = _load(MINIBOT_URDF)
    checked = 0
    for name in ANIMATIONS:
        for keyframe in json.loads((testdata / "animations" / name).read_text())["keyframes"]:
            cfg = {j: float(np.radians(v)) for j, v in keyframe["goals"].items()}
            ours, theirs = _frames(minibot, cfg), _frames(wolfgang, cfg)
            for key in theirs:
                assert np.allclose(ours[key], theirs[key], atol=1e-3), f"{name}: {key}"
                checked += 1
    assert checked > 200


def test_limits_follow_wolfgang(testdata: Path) -> None:
    theirs = {j.get("name"): j.find("limit") for j in
              ET.parse(testdata / "robots" / "wolfgang" / "urdf" / "robot.urdf").getroot().findall("joint")}
    for joint in ET.parse(MINIBOT_URDF).getroot().findall("joint"):
        if joint.get("type") != "revolute":
            continue
        ours, ref = joint.find("limit"), theirs[joint.get("name")]
        assert ours is not None and ref is not None
        for key in ("lower", "upper", "effort", "velocity"):
            assert float(ours.get(key)) == pytest.approx(float(ref.get(key)), abs=0.01), (joint.get("name"), key)


def test_size_and_mass_of_a_kid_size_robot() -> None:
    urdf = _load(MINIBOT_URDF)
    mass = sum(link.inertial.mass for link in urdf.robot.links if link.inertial is not None)
    assert 4.5 < mass < 5.5
    world = SimWorld(n_robots=1)
    robot = world.robots[0]
    world.model.body(robot.head_body)  # exists
    robot.set_pose(0.0, 0.0, 0.0, joints={"LKnee": 0.2618, "RKnee": -0.2618, "LHipPitch": 0.0, "RHipPitch": 0.0,
                                          "LAnklePitch": 0.0, "RAnklePitch": 0.0})
    d, m = world.data, world.model
    top = max(d.geom_xpos[g][2] + m.geom_rbound[g] * 0.5 for g in robot._geoms if m.geom_bodyid[g] == robot.head_body)
    assert 0.65 < top < 0.75
    assert float(sum(m.body_mass[b] for b in robot._bodies)) == pytest.approx(mass, rel=1e-6)


def test_mujoco_model_matches_the_urdf() -> None:
    """Joint names, axes (in the torso frame at the zero pose) and limits survive the URDF -> MjSpec import."""
    world = SimWorld(n_robots=2)
    urdf = _load(MINIBOT_URDF)
    axes = _frames(urdf, {})
    limits = {j.name: (j.limit.lower, j.limit.upper) for j in urdf.robot.joints if j.type == "revolute"}
    for robot in world.robots:
        assert sorted(robot.joint_names) == sorted(JOINTS)
        robot.set_pose(0.0, 0.0, 0.0, joints=dict.fromkeys(JOINTS, 0.0))
        d, m = world.data, world.model
        torso_rot = d.xmat[robot.torso_body].reshape(3, 3)
        for i, name in enumerate(robot.joint_names):
            jid = m.actuator_trnid[robot._act[i], 0]
            world_axis = d.xaxis[jid]
            assert np.allclose(torso_rot.T @ world_axis, axes[name], atol=1e-6), name
            assert (robot.lower[i], robot.upper[i]) == pytest.approx(limits[name])
    assert set(STAND_POSE) == set(JOINTS)
