"""The Minibot's own animations: they load, fit its joint limits, and the stand-ups really stand it up in MuJoCo."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from robot_nodes.sim import RobotHandle, SimWorld
from wire.animation import AnimationPlayer, load_animation, validate

ANIMATIONS = Path(__file__).resolve().parents[1] / "robots" / "minibot" / "animations"
REQUIRED = ("walkready", "init", "falling_front", "falling_back", "stand_up_front", "stand_up_back",
            "penalty_in", "penalty_out", "sit_down", "kick_left", "kick_right")
STANDING_HEIGHT = 0.30  # m, base_link above the ground; walkready stands at about 0.36, a squat is below 0.25
UPRIGHT = 0.9  # torso up-axis z; lying is about +-0.3
CONTROL_STEPS = 5  # 10 ms of 2 ms physics steps between goal updates, like the cm730 node's loop


@pytest.fixture
def world() -> SimWorld:
    return SimWorld(1)


def play(world: SimWorld, robot: RobotHandle, name: str) -> None:
    """Plays one animation from the robot's present pose, sampling goals every 10 ms of sim time."""
    anim = load_animation(ANIMATIONS / f"{name}.json")
    player = AnimationPlayer(anim, dict(zip(robot.joint_names, robot.read().positions.tolist(), strict=True)))
    start = world.time
    while world.time - start < player.duration:
        robot.write_goals(player.joint_names, player.positions(world.time - start))
        world.step(CONTROL_STEPS)
    robot.write_goals(player.joint_names, player.positions(player.duration))


def assert_standing(robot: RobotHandle, when: str) -> None:
    height = float(robot.torso_pose()[0][2])
    assert robot.uprightness() > UPRIGHT, f"{when}: torso tilted, uprightness {robot.uprightness():.2f}"
    assert height > STANDING_HEIGHT, f"{when}: torso only {height:.3f} m above the ground"


@pytest.mark.parametrize("name", REQUIRED)
def test_animation_loads_and_fits_the_joint_limits(world: SimWorld, name: str) -> None:
    robot = world.robots[0]
    anim = load_animation(ANIMATIONS / f"{name}.json")
    assert anim.name == name
    assert anim.keyframes
    limits = {n: (float(lo), float(hi)) for n, lo, hi in zip(robot.joint_names, robot.lower, robot.upper, strict=True)}
    report = validate(anim, joint_limits=limits, joint_names=robot.joint_names, source=name)
    assert report.ok, report.errors
    assert not [w for w in report.warnings if "outside its limits" in w], report.warnings
    # the kicks leave the head where it is: it keeps looking at the ball (robot_nodes/kick/animations.py)
    head = {"HeadPan", "HeadTilt"} if name.startswith("kick_") else set()
    assert set(anim.joints) == set(robot.joint_names) - head, "every animation sets all 20 joints (kicks: 18)"


def test_every_file_is_plain_bitbots_json() -> None:
    for path in ANIMATIONS.glob("*.json"):
        data = json.loads(path.read_text())
        assert data["name"] == path.stem
        for kf in data["keyframes"]:
            assert {"duration", "goals"} <= set(kf)


@pytest.mark.parametrize("posture", ["front", "back"])
def test_stand_up_brings_the_robot_from_lying_to_standing(world: SimWorld, posture: str) -> None:
    robot = world.robots[0]
    world.set_ball(3.0, 3.0)  # the kick-off ball at the centre would prop up a robot lying there
    robot.set_pose(0.0, 0.0, yaw=1.3, posture=posture)
    world.step_for(1.0)  # settle on the ground
    assert robot.uprightness() < 0.5, "starts lying"
    play(world, robot, f"stand_up_{posture}")
    if posture == "back":  # stand_up_back rolls the robot onto its front; the HCM then plays stand_up_front
        play(world, robot, "stand_up_front")
    assert_standing(robot, f"end of stand_up_{posture}")
    world.step_for(3.0)
    assert_standing(robot, f"3 s after stand_up_{posture}")


def test_walkready_holds_the_robot_standing(world: SimWorld) -> None:
    robot = world.robots[0]
    robot.set_pose(0.0, 0.0)
    play(world, robot, "walkready")
    for second in range(10):
        world.step_for(1.0)
        assert_standing(robot, f"{second + 1} s in walkready")
