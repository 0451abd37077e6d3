"""SimWorld: one MuJoCo world (field, ball, N robots) and a RobotHandle per robot that acts like its servo bus."""

from __future__ import annotations

import collections
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from robot_nodes.cm730 import quaternion
from robot_nodes.cm730.backend import BusReading, ImuReading
from robot_nodes.sim.field import KID_SIZE, FieldDimensions
from robot_nodes.sim.lineup import Lineup, Team
from robot_nodes.sim.scene import MINIBOT_URDF, PhysicsConfig, Placement, build_world, default_placements
from robot_nodes.sim.stepping import step_holding_gil, step_releasing_gil

# a stand pose with slightly bent knees (Wolfgang sign conventions; the knee is straight at +-0.2618)
STAND_POSE: dict[str, float] = {
    "HeadPan": 0.0, "HeadTilt": 0.0,
    "LShoulderPitch": 0.0, "LShoulderRoll": 0.0, "LElbow": -0.8,
    "RShoulderPitch": 0.0, "RShoulderRoll": 0.0, "RElbow": 0.8,
    "LHipYaw": 0.0, "LHipRoll": 0.0, "LHipPitch": 0.35, "LKnee": 0.9618, "LAnklePitch": -0.35, "LAnkleRoll": 0.0,
    "RHipYaw": 0.0, "RHipRoll": 0.0, "RHipPitch": -0.35, "RKnee": -0.9618, "RAnklePitch": 0.35, "RAnkleRoll": 0.0,
}

POSTURES = ("standing", "front", "back", "left", "right")  # lying on its front, back or a side

# A sleeping robot (PhysicsConfig.sleep) wakes for a goal this far from the one it last moved to: a Dynamixel MX
# resolves 0.088 deg (0.0015 rad), so a smaller change would not move a real servo either. A standing robot whose
# stance goals wobble by float noise stays asleep.
WAKE_GOAL_RAD = 1e-4
# MuJoCo wakes a sleeping tree that a force is applied to (it has no call to wake one): SimWorld.wake applies this
# one (N m on its first joint, for one step), a billionth of what the lightest servo feels
_WAKE_FORCE = 1e-12
# MuJoCo holds a sleeping robot exactly still, which no robot at rest is: its servos read their positions with this
# noise (rad, a third of an MX servo's step), so its bus does not look stale to the HCM (repeated values)
RESTING_ENCODER_NOISE = 0.0005
# RobotHandle.touching: what lies this close to a robot's geoms touches it (m; contacts are found at 0 and below)
TOUCH_M = 0.005


@dataclass
class ImuNoise:
    """Standard deviations of the simulated IMU's white noise."""

    gyro: float = 0.005  # rad/s
    accel: float = 0.05  # m/s^2
    orientation: float = 0.002  # rad, small rotation about a random axis


@dataclass
class ServoThermal:
    """A first-order servo temperature: heats with torque squared, cools towards the room."""

    ambient: float = 25.0  # deg C
    heat_per_nm2: float = 0.013  # K/s per Nm^2
    time_constant: float = 300.0  # s


class SimError(Exception):
    """Bad input to the simulation (unknown joint, robot or posture)."""


@dataclass(frozen=True, slots=True)
class StateCopy:
    """What the servo buses read, copied after each step: read without the world's lock (never changed)."""

    qpos: np.ndarray
    qvel: np.ndarray
    actuator_force: np.ndarray
    sensordata: np.ndarray
    temperatures: np.ndarray
    asleep: np.ndarray  # per kinematic tree (a robot's ``tree``): MuJoCo put it to sleep


class SimWorld:
    """A Humanoid League kid-size field with a ball and ``n_robots`` Minibots (robot1..robotN, or ``robot_ids``).

    Not thread-safe by itself: code that steps it from one thread and reads it from another holds ``lock``.
    The servo buses of its robots need no lock (MujocoBackend): they read ``latest``, a copy the stepping thread
    makes after each step, and queue their goals and torque switches (``later``) for the next step. With 8
    robots at 100 Hz, 1600 lock round trips a second held the physics thread back whenever a reader that held
    the lock lost the CPU or the GIL (up to 38 ms a step, 20-40 % of the wall time, in a 4 v 4 match).

    Robots and the ball at rest sleep (MuJoCo's sleeping, PhysicsConfig.sleep): MuJoCo stops stepping a robot whose
    every part has moved slower than ``model.opt.sleep_tolerance`` for a few steps and wakes it when something awake
    touches it or a force is applied to it. It does not wake a robot for new servo goals, so the world does
    (``wake``): for a goal that moved more than WAKE_GOAL_RAD, a torque limit or switch, a new pose. A sleeping
    robot's servos report the torque they held when it fell asleep (MuJoCo reports none), its IMU what it read.
    With 8 robots standing, a step took 0.06 ms instead of 0.5.
    """

    def __init__(self, n_robots: int = 1, placements: list[Placement] | None = None,
                 urdf: Path = MINIBOT_URDF, field: FieldDimensions = KID_SIZE,
                 physics: PhysicsConfig | None = None, imu_noise: ImuNoise | None = None,
                 seed: int = 0, robot_ids: list[str] | None = None, lineup: Lineup | None = None) -> None:
        if lineup is not None:  # a match: two teams, robot ids and ends from the lineup
            robot_ids = lineup.robot_ids()
            n_robots = len(robot_ids)
        if n_robots < 1 or n_robots > 30:
            raise SimError(f"n_robots must be 1..30, got {n_robots}")
        placements = placements or default_placements(n_robots)
        if len(placements) < n_robots:
            raise SimError(f"{n_robots} robots need {n_robots} placements, got {len(placements)}")
        self.field = field
        self.physics = physics or PhysicsConfig()
        try:
            self.model, prefixes = build_world(n_robots, placements, urdf, field, self.physics, robot_ids=robot_ids)
        except ValueError as exc:
            raise SimError(str(exc)) from None
        self.data = mujoco.MjData(self.model)
        self.lock = threading.RLock()
        self.hold_gil = False  # step keeping Python's GIL (stepping.py): a world in lockstep
        self.rng = np.random.default_rng(seed)
        self.imu_noise = imu_noise or ImuNoise()
        self.thermal = ServoThermal()
        m = self.model
        self._goal = np.zeros(m.nu)  # where each servo is told to go
        self._speed_limit = np.zeros(m.nu)  # no-load speed of each servo, rad/s
        self._gain = m.actuator_gainprm[:, 0].copy()
        self._bias = m.actuator_biasprm[:, :3].copy()
        self._max_force = m.actuator_forcerange[:, 1].copy()
        self._slewing = False
        self._pushes: list[tuple[float, int, np.ndarray]] = []  # (end time, body, force)
        self._later: collections.deque[Callable[[], None]] = collections.deque()  # changes for the next step
        self._held: collections.deque[Callable[[], None]] | None = None  # changes waiting for release_changes
        self._held_lock = threading.Lock()
        self.robots = [RobotHandle(self, i, prefix) for i, prefix in enumerate(prefixes)]
        self.lineup = lineup
        if lineup is not None:
            for handle in self.robots:
                handle.team, handle.player = lineup.member(handle.robot_id) or (None, 0)
        for handle in self.robots:
            self._speed_limit[handle._act] = handle.max_velocity
            if self.physics.sleep:
                m.tree_sleep_policy[handle.tree] = int(mujoco.mjtSleepPolicy.mjSLEEP_ALLOWED)  # actuated: never
        self._act_tree = m.body_treeid[m.jnt_bodyid[m.actuator_trnid[:, 0]]]
        self._woken_goal = np.zeros(m.nu)  # the goals a robot was last woken for (WAKE_GOAL_RAD)
        self._force = np.zeros(m.nu)  # each servo's torque, kept while its robot sleeps
        self._wake_dofs: list[int] = []  # the first joint of each tree to wake at the next step
        self._vmax = self._speed_limit.copy()
        self.temperatures = np.full(m.nu, self.thermal.ambient)
        self.latest = self.copy_state()
        self._ball_body = m.body("ball").id
        self._ball_qadr = m.jnt_qposadr[m.joint("ball").id]
        self._ball_dadr = m.jnt_dofadr[m.joint("ball").id]
        self._ball_tree = m.body_treeid[self._ball_body]
        for handle in self.robots:
            handle.set_pose(placements[handle.index].x, placements[handle.index].y, placements[handle.index].yaw)
        mujoco.mj_forward(m, self.data)

    # -- time ------------------------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Simulated seconds since the start."""
        return float(self.data.time)

    @property
    def timestep(self) -> float:
        return float(self.model.opt.timestep)

    def later(self, change: Callable[[], None]) -> None:
        """Any thread: ``change`` runs on the stepping thread before the next step, in the order given (held
        until ``release_changes`` once ``hold_changes`` was called)."""
        held = self._held
        if held is None:
            self._later.append(change)
            return
        with self._held_lock:
            self._held.append(change)  # type: ignore[union-attr]  # never None again once held

    def hold_changes(self) -> None:
        """From now on changes wait for ``release_changes``: a lockstep clock (WorldClock) decides at which step the
        motor goals of a tick arrive, not the moment their message happens to come in."""
        with self._held_lock:
            if self._held is None:
                self._held = collections.deque()

    def release_changes(self) -> None:
        """The changes held so far run before the next step; those that come after wait for the next release."""
        with self._held_lock:
            held = self._held
            if held:
                self._later.extend(held)
                held.clear()

    def step(self, n: int = 1) -> None:
        """Advances physics by n steps; servos slew towards their goals at their speed limit."""
        m, d = self.model, self.data
        dt = m.opt.timestep
        while self._later:
            self._later.popleft()()
        remaining = n
        while remaining > 0:
            waking = self._wake_dofs
            if waking:
                self._wake_dofs = []
                d.qfrc_applied[waking] = _WAKE_FORCE
            if self._pushes:
                self._apply_pushes()
            if self._slewing:
                ctrl = d.ctrl
                delta = np.clip(self._goal - ctrl, -self._vmax * dt, self._vmax * dt)
                ctrl += delta
                self._slewing = bool(np.any(np.abs(self._goal - ctrl) > 1e-9))
                chunk = 1
            elif waking:
                chunk = 1
            else:
                chunk = remaining if not self._pushes else max(1, min(remaining, self._push_steps_left()))
            (step_holding_gil if self.hold_gil else step_releasing_gil)(m, d, chunk)
            if waking:
                d.qfrc_applied[waking] = 0.0
            remaining -= chunk
        self._hold_forces()
        self._heat(n * dt)
        self.latest = self._copy()

    def copy_state(self) -> StateCopy:
        """What the servo buses read, as it is now (hold the lock while another thread steps)."""
        self._hold_forces()
        return self._copy()

    def _copy(self) -> StateCopy:
        d = self.data
        return StateCopy(d.qpos.copy(), d.qvel.copy(), self._force.copy(), d.sensordata.copy(),
                         self.temperatures.copy(), d.tree_asleep >= 0)

    def wake(self, tree: int) -> None:
        """On the stepping thread (or holding the lock): the robot or ball of kinematic tree ``tree`` (its
        ``tree``, ``ball_tree``) is stepped again from the next step on, if it sleeps."""
        if self.physics.sleep and self.data.tree_asleep[tree] >= 0:
            self._wake_dofs.append(int(self.model.tree_dofadr[tree]))

    def forward_waking(self, tree: int) -> None:
        """``mj_forward`` after the caller moved tree ``tree`` (a new pose, a ball put down): it is awake then."""
        d = self.data
        dof = int(self.model.tree_dofadr[tree])
        d.qfrc_applied[dof] = _WAKE_FORCE if self.physics.sleep else 0.0
        mujoco.mj_forward(self.model, d)
        d.qfrc_applied[dof] = 0.0

    def step_for(self, seconds: float) -> None:
        self.step(max(1, round(seconds / self.timestep)))

    # -- ball --------------------------------------------------------------------------------------------
    def ball_position(self, state: StateCopy | None = None) -> np.ndarray:
        """Ground truth ball centre in field coordinates (m): now (hold the lock), or in ``state`` (no lock)."""
        if state is not None:
            return state.qpos[self._ball_qadr:self._ball_qadr + 3].copy()
        return self.data.xpos[self._ball_body].copy()

    def set_ball(self, x: float, y: float, velocity: tuple[float, ...] = (0.0, 0.0), height: float | None = None
                 ) -> None:
        """Puts the ball at (x, y), resting on the turf (or its centre at ``height``), moving at ``velocity`` (m/s,
        x y or x y z), not spinning."""
        q = self.data.qpos
        z = self.field.ball_diameter / 2 if height is None else height
        q[self._ball_qadr:self._ball_qadr + 7] = [x, y, z, 1, 0, 0, 0]
        v = self.data.qvel
        vz = velocity[2] if len(velocity) > 2 else 0.0
        v[self._ball_dadr:self._ball_dadr + 6] = [velocity[0], velocity[1], vz, 0, 0, 0]
        self.forward_waking(self._ball_tree)
        self.latest = self.copy_state()

    def robot(self, robot_id: str) -> RobotHandle:
        for handle in self.robots:
            if handle.robot_id == robot_id:
                return handle
        raise SimError(f"no robot {robot_id!r} in this world (have {[r.robot_id for r in self.robots]})")

    # -- internals ---------------------------------------------------------------------------------------
    def _push_steps_left(self) -> int:
        end = min(p[0] for p in self._pushes)
        return max(1, math.ceil((end - self.data.time) / self.model.opt.timestep - 1e-9))

    def _apply_pushes(self) -> None:
        d = self.data
        d.xfrc_applied[:, :3] = 0.0
        self._pushes = [p for p in self._pushes if p[0] > d.time + 1e-9]
        for _end, body, force in self._pushes:
            d.xfrc_applied[body, :3] += force

    def _hold_forces(self) -> None:
        """Servo torques of the robots that are awake; a sleeping one's stay as they were (MuJoCo gives it none)."""
        d = self.data
        awake = d.ntree_awake
        if not self.physics.sleep or awake == self.model.ntree:
            self._force[:] = d.actuator_force
        elif awake:
            np.copyto(self._force, d.actuator_force, where=d.tree_awake[self._act_tree].astype(bool))

    def _heat(self, dt: float) -> None:
        th = self.thermal
        torque = self._force
        cooling = (self.temperatures - th.ambient) / th.time_constant
        self.temperatures += dt * (th.heat_per_nm2 * torque * torque - cooling)


class RobotHandle:
    """One robot of a SimWorld, seen like its servo bus (the ServoBackend calls) plus simulation extras."""

    def __init__(self, world: SimWorld, index: int, prefix: str) -> None:
        m = world.model
        self.world = world
        self.index = index
        self.prefix = prefix
        self.robot_id = prefix.rstrip("/")
        acts = [i for i in range(m.nu) if m.actuator(i).name.startswith(prefix)]
        self.joint_names: list[str] = [m.actuator(i).name[len(prefix):] for i in acts]
        self._act = np.array(acts)
        jnt = [m.actuator_trnid[i, 0] for i in acts]
        self._qadr = np.array([m.jnt_qposadr[j] for j in jnt])
        self._dadr = np.array([m.jnt_dofadr[j] for j in jnt])
        self._index = {name: i for i, name in enumerate(self.joint_names)}
        self.lower = np.array([m.jnt_range[j, 0] for j in jnt])
        self.upper = np.array([m.jnt_range[j, 1] for j in jnt])
        self.max_effort = np.array([m.actuator_forcerange[i, 1] for i in acts])
        self.max_velocity = np.array([_speed_of(name) for name in self.joint_names])
        root = m.joint(prefix + "root").id
        self.tree = int(m.body_treeid[m.jnt_bodyid[root]])  # its kinematic tree (SimWorld.wake)
        self._root_qadr = m.jnt_qposadr[root]
        self._root_dadr = m.jnt_dofadr[root]
        self.base_body = m.body(prefix + "base_link").id
        self.torso_body = m.body(prefix + "torso").id
        self.head_body = m.body(prefix + "head").id
        self.camera_id = m.camera(prefix + "head_camera").id
        self._bodies = [b for b in range(m.nbody) if m.body(b).name.startswith(prefix)]
        self._geoms = [g for g in range(m.ngeom) if m.geom_bodyid[g] in set(self._bodies)]
        self._geom_set = frozenset(self._geoms)
        sensor = {kind: m.sensor(prefix + kind) for kind in ("imu_quat", "imu_gyro", "imu_accel")}
        self._quat_adr = sensor["imu_quat"].adr[0]
        self._gyro_adr = sensor["imu_gyro"].adr[0]
        self._accel_adr = sensor["imu_accel"].adr[0]
        self.torque_enabled = np.ones(len(acts), dtype=bool)
        self.voltage_nominal = 15.2
        self._jersey = [g for g in self._geoms if m.geom_bodyid[g] == self.torso_body]
        # in a match: its team (number, end) and player number, else None and 0
        self.team: Team | None = None
        self.player = 0

    # -- the ServoBackend calls --------------------------------------------------------------------------
    def read(self, state: StateCopy | None = None) -> BusReading:
        """The servo bus's reading of ``state`` (default: the world now; hold the world's lock)."""
        d = state if state is not None else self.world.copy_state()
        efforts = d.actuator_force[self._act]  # fancy indexing: a copy
        positions = d.qpos[self._qadr]
        if d.asleep[self.tree]:
            positions += self.world.rng.normal(0.0, RESTING_ENCODER_NOISE, len(positions))
        return BusReading(
            positions=positions,
            velocities=d.qvel[self._dadr],
            efforts=efforts,
            imu=self.imu(d),
            temperatures=d.temperatures[self._act],
            voltage=float(self.voltage_nominal - 0.02 * np.abs(efforts).sum()),
        )

    def imu(self, d: StateCopy) -> ImuReading:
        """Torso IMU of state ``d`` with white noise as configured in world.imu_noise.

        Every robot's IMU is read 100 times a simulated second, so this is scalar arithmetic on Python floats and one
        draw of the noises (the same numbers, in the same order, as a draw per noise)."""
        noise, sensors = self.world.imu_noise, d.sensordata
        w, x, y, z = sensors[self._quat_adr:self._quat_adr + 4].tolist()
        draws = self.world.rng.standard_normal(9 if noise.orientation > 0 else 6)
        if noise.orientation > 0:  # the measured orientation turned by a small rotation about a random axis
            x, y, z, w = quaternion.multiply((x, y, z, w), quaternion.from_rotation_vector(
                *(draws[:3] * noise.orientation).tolist()))
            draws = draws[3:]
        norm = math.sqrt(x * x + y * y + z * z + w * w)
        gyro = sensors[self._gyro_adr:self._gyro_adr + 3] + draws[:3] * noise.gyro
        accel = sensors[self._accel_adr:self._accel_adr + 3] + draws[3:6] * noise.accel
        return ImuReading(np.array([x / norm, y / norm, z / norm, w / norm]), gyro, accel)

    def write_goals(self, names: list[str], positions: np.ndarray, velocities: np.ndarray | None = None,
                    efforts: np.ndarray | None = None) -> None:
        """Goal positions (rad), clipped to the joint limits. velocities: rad/s speed limit (0 = the servo's
        maximum); efforts: torque limit in Nm (<= 0 or NaN = the servo's maximum)."""
        self.goal_change(names, positions, velocities, efforts)()

    def goal_change(self, names: list[str], positions: np.ndarray, velocities: np.ndarray | None = None,
                    efforts: np.ndarray | None = None) -> Callable[[], None]:
        """write_goals checked and computed now (SimError for bad input, on the caller's thread), applied when the
        returned function is called (by the stepping thread: SimWorld.later)."""
        idx = self._indices(names)
        positions = np.asarray(positions, dtype=float)
        if positions.shape != (len(idx),) or not np.all(np.isfinite(positions)):
            raise SimError(f"need {len(idx)} finite goal positions, got {positions!r}")
        acts = self._act[idx]
        goal = np.clip(positions, self.lower[idx], self.upper[idx])
        speed = None
        if velocities is not None:
            v = np.asarray(velocities, dtype=float)
            top = self.max_velocity[idx]
            speed = np.where(np.isfinite(v) & (v > 0), np.minimum(np.abs(v), top), top)
        force = None
        if efforts is not None:
            e = np.asarray(efforts, dtype=float)
            force = np.where(np.isfinite(e) & (e > 0), np.minimum(e, self.max_effort[idx]), self.max_effort[idx])
        w = self.world

        def apply() -> None:
            w._goal[acts] = goal
            moved = bool(np.any(np.abs(goal - w._woken_goal[acts]) > WAKE_GOAL_RAD))
            if speed is not None:
                w._vmax[acts] = speed
            if force is not None:
                moved = moved or bool(np.any(w.model.actuator_forcerange[acts, 1] != force))
                w.model.actuator_forcerange[acts, 0] = -force
                w.model.actuator_forcerange[acts, 1] = force
            if moved:
                w._woken_goal[acts] = goal
                w.wake(self.tree)
            w._slewing = True

        return apply

    def set_torque(self, names: list[str], enabled: bool) -> None:
        """Torque off makes a joint really limp (no stiffness, only gearbox damping and friction).
        Torque on holds the present position, as a Dynamixel does; enabling a servo that is already on changes
        nothing, so a torque switch that arrives after its goals does not undo them."""
        idx = self._indices(names)
        if enabled:
            idx = idx[~self.torque_enabled[idx]]
        w, m, d = self.world, self.world.model, self.world.data
        acts = self._act[idx]
        if enabled:
            m.actuator_gainprm[acts, 0] = w._gain[acts]
            m.actuator_biasprm[acts, :3] = w._bias[acts]
            here = np.clip(d.qpos[self._qadr[idx]], self.lower[idx], self.upper[idx])
            d.ctrl[acts] = here
            w._goal[acts] = here
            w._woken_goal[acts] = here
        else:
            m.actuator_gainprm[acts, 0] = 0.0
            m.actuator_biasprm[acts, :3] = 0.0
        if len(idx):
            w.wake(self.tree)
        self.torque_enabled[idx] = enabled

    def close(self) -> None:
        """The world outlives its robots; nothing to release."""

    # -- simulation extras ------------------------------------------------------------------------------
    def apply_push(self, force_xyz: tuple[float, float, float], duration: float) -> None:
        """A force (N, field frame) on the torso's centre of mass for ``duration`` simulated seconds."""
        w = self.world
        w._pushes.append((w.time + duration, self.torso_body, np.asarray(force_xyz, dtype=float)))
        w._apply_pushes()

    def set_pose(self, x: float, y: float, yaw: float = 0.0, posture: str = "standing",
                 joints: dict[str, float] | None = None) -> None:
        """Puts the robot at rest at (x, y, yaw) on the field: standing on its soles, or lying on its front,
        back or a side; joints (default STAND_POSE) are also its new goals, with torque on."""
        if posture not in POSTURES:
            raise SimError(f"posture must be one of {POSTURES}, got {posture!r}")
        w, m, d = self.world, self.world.model, self.world.data
        pose = dict(STAND_POSE)
        pose.update(joints or {})
        names = list(pose)
        idx = self._indices(names)
        values = np.clip(np.array([pose[n] for n in names]), self.lower[idx], self.upper[idx])
        d.qpos[self._qadr[idx]] = values
        d.qvel[self._dadr] = 0.0
        d.qvel[self._root_dadr:self._root_dadr + 6] = 0.0
        pitch = {"front": math.pi / 2, "back": -math.pi / 2}.get(posture, 0.0)
        roll = {"left": -math.pi / 2, "right": math.pi / 2}.get(posture, 0.0)  # the HCM's sides (fused roll)
        tilt = _quat_mul_wxyz(np.array([math.cos(pitch / 2), 0.0, math.sin(pitch / 2), 0.0]),
                              np.array([math.cos(roll / 2), math.sin(roll / 2), 0.0, 0.0]))
        quat = _quat_mul_wxyz(_yaw_wxyz(yaw), tilt)
        d.qpos[self._root_qadr:self._root_qadr + 7] = [x, y, 1.0, *quat]
        mujoco.mj_kinematics(m, d)
        lowest = self._lowest_point()
        d.qpos[self._root_qadr + 2] = 1.0 - lowest + 0.002
        self.set_torque(self.joint_names, True)
        w._goal[self._act[idx]] = values
        w._woken_goal[self._act[idx]] = values
        d.ctrl[self._act[idx]] = values
        w.forward_waking(self.tree)
        w.latest = w.copy_state()

    def set_jersey(self, rgba: tuple[float, float, float, float]) -> None:
        """Colours the torso (the team's colour in a match; cameras see it)."""
        self.world.model.geom_rgba[self._jersey] = rgba

    def jersey(self) -> tuple[float, ...]:
        return tuple(float(v) for v in self.world.model.geom_rgba[self._jersey[0]]) if self._jersey else ()

    def torso_pose(self, state: StateCopy | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Ground truth (position xyz, orientation xyzw) of base_link in the field frame: now (hold the lock), or in
        ``state`` (no lock; base_link carries the robot's free joint, so its pose is that joint's qpos)."""
        if state is not None:
            x, y, z, qw, qx, qy, qz = state.qpos[self._root_qadr:self._root_qadr + 7].tolist()
            norm = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz) or 1.0
            return np.array([x, y, z]), np.array([qx, qy, qz, qw]) / norm
        d = self.world.data
        w, x, y, z = d.xquat[self.base_body]
        return d.xpos[self.base_body].copy(), np.array([x, y, z, w])

    def pose2d(self) -> tuple[float, float, float]:
        """Ground truth (x, y, yaw) on the field."""
        d = self.world.data
        xmat = d.xmat[self.base_body].reshape(3, 3)
        return float(d.xpos[self.base_body, 0]), float(d.xpos[self.base_body, 1]), math.atan2(xmat[1, 0], xmat[0, 0])

    def uprightness(self) -> float:
        """z component of the torso's up axis in the world: 1 upright, 0 lying, -1 upside down."""
        return float(self.world.data.xmat[self.torso_body].reshape(3, 3)[2, 2])

    def touching(self) -> list[str]:
        """What the robot touches now besides the turf and itself (hold the lock): other robots by id, the ball, goal
        posts, crossbars and nets by geom name. Said with a robot that cannot get up (what holds it down). The contacts
        of the last step, and what lies within TOUCH_M of its geoms: MuJoCo keeps no contacts for bodies that sleep,
        so a robot lying still on the ball or another robot between two tries is found by distance."""
        m, d = self.world.model, self.world.data
        mine = self._geom_set
        found: set[str] = set()
        for contact in d.contact[:d.ncon]:
            g1, g2 = int(contact.geom1), int(contact.geom2)
            if (g1 in mine) != (g2 in mine):
                found.update(self._what(g2 if g1 in mine else g1))
        others = np.array([g for g in range(m.ngeom) if g not in mine and (m.geom_contype[g] or m.geom_conaffinity[g])
                           and m.geom_type[g] != mujoco.mjtGeom.mjGEOM_PLANE])
        own = np.array(self._geoms)
        # bounding spheres first: the exact distance only for the few pairs that may be that close
        gap = np.linalg.norm(d.geom_xpos[own][:, None, :] - d.geom_xpos[others][None, :, :], axis=2)
        near = gap < m.geom_rbound[own][:, None] + m.geom_rbound[others][None, :] + TOUCH_M
        for i, j in zip(*np.nonzero(near), strict=True):
            if mujoco.mj_geomDistance(m, d, int(own[i]), int(others[j]), TOUCH_M, None) < TOUCH_M:
                found.update(self._what(int(others[j])))
        return sorted(found)

    def _what(self, geom: int) -> list[str]:
        """What a geom that is not this robot's belongs to, as ``touching`` names it (nothing for the turf and its
        lines, where a robot lies anyway)."""
        m = self.world.model
        body = int(m.geom_bodyid[geom])
        if body == 0:  # the world's static geoms
            name = m.geom(geom).name
            return [] if name == "turf" or name.startswith("line") else [name]
        owner = next((r.robot_id for r in self.world.robots if geom in r._geom_set), None)
        return [owner or m.body(body).name]

    # -- internals ---------------------------------------------------------------------------------------
    def check_joints(self, names: list[str]) -> None:
        """SimError for a joint this robot does not have."""
        self._indices(names)

    def _indices(self, names: list[str]) -> np.ndarray:
        unknown = [n for n in names if n not in self._index]
        if unknown:
            raise SimError(f"unknown joint(s) {unknown} (known: {self.joint_names})")
        return np.array([self._index[n] for n in names], dtype=int)

    def _lowest_point(self) -> float:
        """Lowest z of the robot's collision geoms (boxes and cylinders exactly enough for placing)."""
        m, d = self.world.model, self.world.data
        lowest = math.inf
        for g in self._geoms:
            pos, mat, size = d.geom_xpos[g], d.geom_xmat[g].reshape(3, 3), m.geom_size[g]
            kind = m.geom_type[g]
            if kind == mujoco.mjtGeom.mjGEOM_BOX:
                extent = np.abs(mat[2]) @ size
            elif kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
                axis_z = abs(mat[2, 2])
                extent = size[1] * axis_z + size[0] * math.sqrt(max(0.0, 1 - axis_z * axis_z))
            else:
                extent = m.geom_rbound[g]
            lowest = min(lowest, pos[2] - extent)
        return lowest


def _speed_of(joint: str) -> float:
    """No-load speed (rad/s) of the servo model at 14.8 V, as in the URDF's velocity limits."""
    if "Knee" in joint:
        return 3.87
    if "Hip" in joint or "Ankle" in joint:
        return 5.76
    return 8.17


def _yaw_wxyz(yaw: float) -> np.ndarray:
    return np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])


def _quat_mul_wxyz(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.zeros(4)
    mujoco.mju_mulQuat(out, a, b)
    return out
