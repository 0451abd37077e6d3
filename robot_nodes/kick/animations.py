"""The Minibot's kick animations (robots/minibot/animations/kick_left.json, kick_right.json), made from foot poses.

    python -m robot_nodes.kick.animations      # writes both files again after a change of KICK

A kick is six keyframes: shift the torso over the standing foot, lift and wind the kicking foot back, strike through
the ball as fast as the hip and knee servos turn, pull back, put the foot down, stand again. The poses are written as
where each sole is (base_link frame: x forward, y left, z up) and turned into joint angles by the walking engine's
leg IK (robot_nodes/walking/kinematics.py), so they follow the URDF; the right kick is the left one mirrored.
KICK holds the numbers, chosen by a random search on the simulated Minibot: the strongest strike that kept it upright
in 32 of 32 kicks from feet up to 2 cm off their stance, the ball up to 3 cm off its spot, and the animation played up
to 20 % fast (a machine that cannot keep real time); tests/test_kick_sim.py measures the kick with every node.

The ball sits best about 0.2 m in front of base_link, in front of the kicking foot's centre (robot_nodes/kick).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import robots
from robot_nodes.walking.kinematics import LegKinematics, rot_y
from wire.animation.animation_file import Animation, Keyframe, save_animation
from wire.animation.editing import mirror


@dataclass(frozen=True)
class KickShape:
    """The kick in numbers (m, rad, s); soles relative to base_link."""

    height: float = 0.338  # base_link above the soles while kicking
    foot_y: float = 0.06  # each sole's distance from the middle, standing
    foot_x: float = 0.02  # soles ahead of base_link, standing
    shift: float = 0.057  # the torso moves this far over the standing foot
    lean: float = 0.042  # torso pitched forward
    back_x: float = -0.06  # the kicking sole wound back to here...
    back_z: float = 0.079  # ...this high
    strike_x: float = 0.178  # and swung through to here...
    strike_z: float = 0.074  # ...this high (the ball's centre is 0.075 m up)
    arm_swing_deg: float = 29.0  # arms swing against the kick, for balance
    t_shift: float = 0.47
    pause_shift: float = 0.46  # the torso settles over the standing foot before the leg lifts
    t_wind_up: float = 0.35
    t_strike: float = 0.12  # faster than the servos can follow: they go at their top speed
    t_retract: float = 0.48
    t_put_down: float = 0.59
    t_stand: float = 0.54

KICK = KickShape()
ARMS = {"LShoulderPitch": 0.0, "LShoulderRoll": 0.0, "LElbow": -45.8, "RShoulderPitch": 0.0, "RShoulderRoll": 0.0,
        "RElbow": 45.8}  # degrees, as in walkready


def legs(kin: LegKinematics, left: tuple[float, float, float], right: tuple[float, float, float],
         lean: float) -> dict[str, float]:
    """Joint goals (degrees) for the two soles at these places, flat on the ground, the torso leaning by ``lean``."""
    turn = rot_y(-lean)  # leaning the torso forward turns the world (and the soles) backwards in base_link
    goals: dict[str, float] = {}
    for leg, sole in ((kin.left, left), (kin.right, right)):
        q = leg.ik(turn @ sole, turn)
        goals.update({name: round(math.degrees(v), 2) for name, v in zip(leg.joint_names(), q, strict=True)})
    return goals


def kick_left(shape: KickShape = KICK, kin: LegKinematics | None = None) -> Animation:
    kin = kin or LegKinematics.from_urdf()
    s = shape
    y_left, y_right = s.foot_y + s.shift, -s.foot_y + s.shift

    def left_at(x: float, z: float = 0.0) -> tuple[float, float, float]:
        return (x, y_left, -s.height + z)

    right = (s.foot_x, y_right, -s.height)
    swing = dict(ARMS, RShoulderPitch=s.arm_swing_deg, LShoulderPitch=-s.arm_swing_deg)
    frames = [
        ("shift", legs(kin, left_at(s.foot_x), right, s.lean), ARMS, s.t_shift, s.pause_shift),
        ("wind_up", legs(kin, left_at(s.back_x, s.back_z), right, s.lean), ARMS, s.t_wind_up, 0.0),
        ("strike", legs(kin, left_at(s.strike_x, s.strike_z), right, s.lean), swing, s.t_strike, 0.0),
        ("retract", legs(kin, left_at(s.foot_x, 0.6 * s.back_z), right, s.lean), ARMS, s.t_retract, 0.0),
        ("put_down", legs(kin, left_at(s.foot_x), right, s.lean), ARMS, s.t_put_down, 0.1),
        ("stand", legs(kin, (s.foot_x, s.foot_y, -s.height), (s.foot_x, -s.foot_y, -s.height), 0.0), ARMS,
         s.t_stand, 0.0),
    ]
    return Animation(
        name="kick_left", author="pitchside", version="2",
        description="kick with the left foot: torso over the right foot, wind up, strike at full servo speed, "
                    "stand (robots/minibot/generate_kicks.py)",
        keyframes=[Keyframe(goals={**leg_goals, **arms}, duration=duration, pause=pause, name=name)
                   for name, leg_goals, arms, duration, pause in frames])


def kick_right(shape: KickShape = KICK) -> Animation:
    out = mirror(kick_left(shape))
    out.name = "kick_right"
    out.description = ("kick with the right foot: kick_left mirrored (robot_nodes/kick/animations.py)")
    return out


def main() -> None:
    for anim in (kick_left(), kick_right()):
        path = save_animation(anim, robots.animations_dir("minibot") / f"{anim.name}.json")
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
