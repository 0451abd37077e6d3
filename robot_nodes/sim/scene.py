"""Builds the MuJoCo world with mujoco.MjSpec: HL kid-size field, goals, ball and N robots from the URDF."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

import robots
from robot_nodes.sim.field import KID_SIZE, FieldDimensions, goal_posts, line_segments

MINIBOT_URDF = robots.urdf("minibot")

# geom groups: 0 robots and ball, 1 field furniture (goals), 2 painted lines (never hit by rays)
GROUP_LINES = 2
TURF = (0.16, 0.48, 0.18, 1.0)
WHITE = (0.95, 0.95, 0.95, 1.0)
BALL_RGBA = (1.0, 0.35, 0.0, 1.0)  # orange: stands out against turf, lines and robots in the camera image
ROBOT_RGBA = ((0.25, 0.25, 0.28, 1.0), (0.12, 0.12, 0.14, 1.0))


@dataclass(frozen=True, slots=True)
class ServoClass:
    """Position-controller gains of one Dynamixel type, as seen by MuJoCo."""

    kp: float  # Nm/rad
    kv: float  # Nm s/rad


@dataclass(frozen=True)
class PhysicsConfig:
    timestep: float = 0.002
    mx64: ServoClass = ServoClass(kp=12.0, kv=0.2)  # head and arms
    # legs: stiff enough that a leg carrying the body sags < 1.5 deg (at 40 Nm/rad it was 4 deg). An integral
    # term (a Dynamixel's Position I Gain) removed the sag too but made the walking robot fall: it fights
    # the other leg through the ground and lags the gait.
    mx106: ServoClass = ServoClass(kp=100.0, kv=1.5)
    armature: float = 0.012  # kg m^2, reflected rotor inertia through the servo gearbox
    turf_friction: tuple[float, float, float] = (1.0, 0.005, 0.0001)  # sliding, torsional, rolling
    # rolling 0.01 m: artificial turf (FIFA's ball-roll test: 4-10 m from its ramp); a kicked ball rolls metres
    ball_friction: tuple[float, float, float] = (0.8, 0.005, 0.01)
    foot_friction: float = 1.0
    solver_iterations: int = 30
    # robots and the ball at rest are not stepped (MuJoCo's sleeping, SimWorld.wake): a robot standing still
    # costs the physics almost nothing, one that moves or is touched wakes
    sleep: bool = True


@dataclass(frozen=True)
class Placement:
    """Where a robot starts: field coordinates (m, rad)."""

    x: float
    y: float
    yaw: float = 0.0


def default_placements(n: int) -> list[Placement]:
    """Robots side by side on their own half, 0.8 m apart, facing the opponent goal (+x)."""
    return [Placement(-1.5 - 0.9 * (i // 6), (i % 6 - (min(n, 6) - 1) / 2) * 0.8) for i in range(n)]


def _robot_spec(urdf_text: str, prefix_index: int, n_robots: int, physics: PhysicsConfig) -> mujoco.MjSpec:
    text = urdf_text.replace(
        "<robot name=\"minibot\">",
        '<robot name="minibot"><mujoco><compiler fusestatic="false" discardvisual="true"/></mujoco>', 1)
    spec = mujoco.MjSpec.from_string(text)
    base = spec.body("base_link")
    base.add_freejoint(name="root")
    # collision masks: a robot touches the floor, the ball, goals and the other robots, never itself
    own = 1 << (1 + prefix_index % 30)
    others = sum(1 << (1 + i % 30) for i in range(n_robots) if i != prefix_index) & ~own
    for g in spec.geoms:
        g.contype = own
        g.conaffinity = 1 | others
        g.condim = 3
        g.friction = [physics.foot_friction, 0.005, 0.0001]
        g.rgba = ROBOT_RGBA[1] if g.parent.name in ("torso", "head", "l_foot", "r_foot") else ROBOT_RGBA[0]
        g.group = 0
    for j in spec.joints:
        if j.type == mujoco.mjtJoint.mjJNT_HINGE:
            j.armature = physics.armature
            servo = physics.mx106 if ("Hip" in j.name or "Knee" in j.name or "Ankle" in j.name) else physics.mx64
            effort = float(j.actfrcrange[1])
            act = spec.add_actuator(name=j.name, target=j.name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
            act.set_to_position(kp=servo.kp, kv=servo.kv)
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
            act.forcerange = [-effort, effort]
            act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
            act.ctrlrange = list(j.range)
    spec.body("imu_frame").add_site(name="imu", size=[0.005, 0.005, 0.005])
    for kind, name in ((mujoco.mjtSensor.mjSENS_FRAMEQUAT, "imu_quat"), (mujoco.mjtSensor.mjSENS_GYRO, "imu_gyro"),
                       (mujoco.mjtSensor.mjSENS_ACCELEROMETER, "imu_accel")):
        spec.add_sensor(name=name, type=kind, objtype=mujoco.mjtObj.mjOBJ_SITE, objname="imu")
    # MuJoCo cameras look along their -z with y up; the camera link has x forward, z up
    # (quat of xyaxes = (0 -1 0, 0 0 1): camera x = link -y (right), camera y = link z (up))
    spec.body("camera").add_camera(name="head_camera", fovy=HEAD_CAMERA_FOVY_DEG, quat=[0.5, 0.5, -0.5, -0.5])
    return spec


HEAD_CAMERA_FOVY_DEG = 50.0  # about 64 degrees horizontal at 4:3, like a wide kid-size camera lens


def _add_field(world: mujoco.MjSpec, f: FieldDimensions, physics: PhysicsConfig) -> None:
    robots_mask = 0x7FFFFFFE
    half = (f.length / 2 + f.border_strip + 0.5, f.width / 2 + f.border_strip + 0.5)
    world.worldbody.add_geom(name="turf", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[half[0], half[1], 0.1],
                             rgba=TURF, friction=list(physics.turf_friction), contype=1, conaffinity=robots_mask)
    thickness = 0.001
    for i, ((x0, y0), (x1, y1)) in enumerate(line_segments(f)):
        length = math.hypot(x1 - x0, y1 - y0)
        length += f.line_width if length > 0.3 else 0.01  # long lines overlap at the corners
        yaw = math.atan2(y1 - y0, x1 - x0)
        world.worldbody.add_geom(
            name=f"line{i}", type=mujoco.mjtGeom.mjGEOM_BOX, size=[length / 2, f.line_width / 2, thickness],
            pos=[(x0 + x1) / 2, (y0 + y1) / 2, thickness], quat=_yaw_quat(yaw), rgba=WHITE,
            contype=0, conaffinity=0, group=GROUP_LINES)
    r = f.post_diameter / 2
    for i, (px, py) in enumerate(goal_posts(f)):
        world.worldbody.add_geom(name=f"goal_post{i}", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                                 size=[r, (f.goal_height + r) / 2, 0], pos=[px, py, (f.goal_height + r) / 2],
                                 rgba=WHITE, contype=1, conaffinity=robots_mask | 1, group=1)
    for sx in (1.0, -1.0):
        gx = sx * (f.length / 2 + r)
        span = f.goal_width / 2 + f.post_diameter
        world.worldbody.add_geom(name=f"crossbar{'+' if sx > 0 else '-'}", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                                 size=[r, span, 0], pos=[gx, 0.0, f.goal_height + r], quat=_roll_quat(math.pi / 2),
                                 rgba=WHITE, contype=1, conaffinity=robots_mask | 1, group=1)
        # the goal's back: a thin net wall that stops the ball, grey so vision does not call it a post
        back = sx * (f.length / 2 + f.goal_depth)
        world.worldbody.add_geom(name=f"goal_net{'+' if sx > 0 else '-'}", type=mujoco.mjtGeom.mjGEOM_BOX,
                                 size=[0.01, f.goal_width / 2, f.goal_height / 2], pos=[back, 0, f.goal_height / 2],
                                 rgba=(0.7, 0.7, 0.7, 0.35), contype=1, conaffinity=robots_mask | 1, group=1)
    ball = world.worldbody.add_body(name="ball", pos=[0.0, 0.0, f.ball_diameter / 2])
    ball.add_freejoint(name="ball")
    radius = f.ball_diameter / 2
    inertia = 2.0 / 3.0 * f.ball_mass * radius**2  # a thin-walled sphere
    ball.add_geom(name="ball", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[radius, 0, 0], rgba=BALL_RGBA,
                  mass=f.ball_mass, contype=1, conaffinity=robots_mask | 1, condim=6,
                  friction=list(physics.ball_friction), priority=1)
    ball.explicitinertial = True
    ball.ipos = [0.0, 0.0, 0.0]  # unset, MuJoCo put the centre of mass on the surface and the ball wobbled to a stop
    ball.iquat = [1.0, 0.0, 0.0, 0.0]
    ball.mass = f.ball_mass
    ball.inertia = [inertia, inertia, inertia]


def _yaw_quat(yaw: float) -> list[float]:
    return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]


def _roll_quat(roll: float) -> list[float]:
    return [math.cos(roll / 2), math.sin(roll / 2), 0.0, 0.0]


def build_world(n_robots: int, placements: list[Placement], urdf_path: Path = MINIBOT_URDF,
                f: FieldDimensions = KID_SIZE, physics: PhysicsConfig | None = None,
                render_size: tuple[int, int] = (640, 480),
                robot_ids: list[str] | None = None) -> tuple[mujoco.MjModel, list[str]]:
    """The compiled model and the robots' name prefixes ("robot1/", ... or "<robot id>/" of robot_ids)."""
    ids = robot_ids or [f"robot{i + 1}" for i in range(n_robots)]
    if len(ids) != n_robots or len(set(ids)) != n_robots or any("/" in r or not r for r in ids):
        raise ValueError(f"{n_robots} robots need as many different robot ids without '/', got {ids}")
    physics = physics or PhysicsConfig()
    world = mujoco.MjSpec()
    world.modelname = "pitchside_field"
    world.option.timestep = physics.timestep
    world.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    world.option.iterations = physics.solver_iterations
    world.option.noslip_iterations = 0
    if physics.sleep:
        world.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    world.visual.global_.offwidth = max(render_size[0], 640)
    world.visual.global_.offheight = max(render_size[1], 480)
    world.visual.headlight.ambient = [0.45, 0.45, 0.45]
    world.visual.headlight.diffuse = [0.5, 0.5, 0.5]
    world.worldbody.add_light(name="sun", pos=[0, 0, 10], dir=[0.2, 0.1, -1], diffuse=[0.5, 0.5, 0.5],
                              type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, castshadow=False)
    _add_field(world, f, physics)
    urdf_text = urdf_path.read_text()
    prefixes = []
    for i in range(n_robots):
        prefix = f"{ids[i]}/"
        place = placements[i]
        frame = world.worldbody.add_frame(pos=[place.x, place.y, 0.0], quat=_yaw_quat(place.yaw))
        frame.attach_body(_robot_spec(urdf_text, i, n_robots, physics).body("base_link"), prefix, "")
        prefixes.append(prefix)
    return world.compile(), prefixes


def yaw_of(quat_wxyz: np.ndarray) -> float:
    w, x, y, z = quat_wxyz
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
