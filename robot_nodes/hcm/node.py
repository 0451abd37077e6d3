"""The HCM node: the only writer of motor_goals; decides per callback which goal stream passes (thesis 5.2.1)."""

from __future__ import annotations

import dataclasses
import math
import threading
from dataclasses import dataclass
from typing import Any

import numpy as np

import schemas
from robot_nodes.hcm.fall_checker import FallChecker, FallThresholds
from robot_nodes.hcm.joint_mutex import GoalSource, passes
from robot_nodes.hcm.state_machine import PUBLISHED_VALUE, Blackboard, HcmState, HcmStateMachine
from robot_nodes.runtime import GoalStatus, Node, header, param
from schemas.messages import (
    AdditionalServoData,
    Animation,
    PlayAnimationGoal,
    RobotControlState,
    ServoHealth,
    Speak,
    StateMachineGraph,
)
from schemas.std import Bool, Imu, JointState, JointTrajectory
from wire.actions import ClientGoal

SHUTDOWN_DEADLINE_S = 4.0  # wall seconds from a stop request to the process's end, sat down or not


@dataclass
class HcmParams:
    rate_hz: float = param(100.0, range=(10.0, 1000.0), doc="state machine evaluations per second")
    state_publish_hz: float = param(10.0, range=(1.0, 100.0), doc="robot_state is also sent at this steady rate")
    falling_gyro_pitch: float = param(7.0, range=(0.5, 30.0), doc="rad/s near upright that counts as falling (pitch)")
    falling_gyro_roll: float = param(7.0, range=(0.5, 30.0), doc="rad/s near upright that counts as falling (roll)")
    falling_no_return_pitch_deg: float = param(45.0, range=(5.0, 89.0), doc="tilt past which any motion is a fall")
    falling_no_return_roll_deg: float = param(60.0, range=(5.0, 89.0), doc="tilt past which any motion is a fall")
    falling_smoothing_s: float = param(0.04, range=(0.0, 0.5), doc="every reading in this window must say falling")
    fallen_orientation_deg: float = param(60.0, range=(20.0, 89.0), doc="tilt that counts as lying")
    fallen_at_rest_gyro: float = param(0.2, range=(0.01, 2.0), doc="rad/s below which a lying robot is at rest")
    upright_deg: float = param(30.0, range=(5.0, 60.0), doc="tilt below which the robot counts as upright")
    fall_detection: bool = param(True, doc="detect falls and play the protective animation")
    stand_up: bool = param(True, doc="stand up by itself after a fall")
    imu_timeout_s: float = param(0.5, range=(0.05, 10.0), doc="IMU silent this long -> HARDWARE_PROBLEM")
    motor_timeout_s: float = param(0.5, range=(0.05, 10.0), doc="joint_states silent this long -> HARDWARE_PROBLEM")
    motor_off_after_s: float = param(0.0, range=(0.0, 3600.0), doc="switch motors off after this idle time (0: never)")
    penalty_torque_off: bool = param(True, doc="go limp while penalized (else hold the penalty pose)")
    record_mode: bool = param(False, doc="RECORD: only the animation recorder's goals reach the motors")
    battery_low_v: float = param(0.0, range=(0.0, 30.0), doc="announce 'battery low' below this voltage (0: off)")
    anim_walkready: str = param("walkready", doc="animation names the HCM plays")
    anim_falling_front: str = param("falling_front", doc="")
    anim_falling_back: str = param("falling_back", doc="")
    anim_falling_left: str = param("falling_front", doc="")
    anim_falling_right: str = param("falling_front", doc="")
    anim_stand_up_front: str = param("stand_up_front", doc="")
    anim_stand_up_back: str = param("stand_up_back", doc="")
    anim_turning_front: str = param("walkready", doc="lying on a side: tips the robot onto its front or back "
                                                     "(Bit-Bots play walkready; the Minibot has turning_front)")
    anim_penalty_in: str = param("penalty_in", doc="")
    anim_penalty_out: str = param("penalty_out", doc="")
    anim_shutdown: str = param("sit_down", doc="")


class HcmNode(Node):
    """Hardware control manager: falls, getting up, penalties, and arbitration of motor goals."""

    name = "hcm"
    Params = HcmParams

    def setup(self) -> None:
        self.bb = Blackboard(now=self.now())
        self.fall_checker = FallChecker()
        self.machine = HcmStateMachine(actions=self, animations=self._animation_names(),
                                       penalty_torque_off=self.params.penalty_torque_off)
        self._apply_thresholds()
        self.joint_names: list[str] = []
        self.last_imu = -math.inf
        self.last_joints = -math.inf
        self.last_joint_positions: np.ndarray | None = None
        self.last_motion = self.now()
        self.last_external_animation = -math.inf
        self.external_animation_over = True
        self.last_walk_goal = -math.inf
        self.walking_active_flag = False
        self.own_goal: ClientGoal | None = None
        self.forwarded = dict.fromkeys(GoalSource, 0)
        self.battery_announced = False
        self.missing_servos = ""  # what the servo bus reports as not answering (servo_health), comma-separated
        self._shutdown_requested_at: float | None = None

        self.goals_pub = self.publisher("motor_goals")
        self.torque_pub = self.publisher("motor_torque")
        self.state_pub = self.publisher("robot_state")
        self.graph_pub = self.publisher("hcm_graph")
        self.speak_pub = self.publisher("speak")
        self.animations = self.action_client("animation")
        # read at each step (100 Hz), each new message once: the sensors do not wake the HCM between its steps
        self.imu = self.keep_latest("imu/data")
        self.joints = self.keep_latest("joint_states")
        self._imu_seen: Imu | None = None
        self._joints_seen: JointState | None = None
        self.subscribe("walk_motor_goals", lambda m: self.on_goals(GoalSource.WALKING, m))
        self.subscribe("head_motor_goals", lambda m: self.on_goals(GoalSource.HEAD, m))
        self.subscribe("record_motor_goals", lambda m: self.on_goals(GoalSource.RECORD, m))
        self.subscribe("animation", self.on_animation)
        self.subscribe("paused", self.on_paused)
        self.subscribe("walking_active", self.on_walking_active)
        self.subscribe("servo_data", self.on_servo_data)
        self.subscribe("servo_health", self.on_servo_health)
        self.step_timer = self.timer(self.step, rate_hz=self.params.rate_hz)
        self.state_timer = self.timer(self.publish_state, rate_hz=self.params.state_publish_hz)
        self.timer(self.publish_graph, rate_hz=1.0)
        self.publish_state()

    # -- inputs -------------------------------------------------------------------------------------------
    def take_sensors(self) -> None:
        """The IMU and joint_states that arrived since the last step, each once, with their arrival times."""
        imu, joints = self.imu.message, self.joints.message
        if imu is not None and imu is not self._imu_seen:
            self._imu_seen = imu
            self.on_imu(imu, self.imu.received_at)
        if joints is not None and joints is not self._joints_seen:
            self._joints_seen = joints
            self.on_joint_states(joints, self.joints.received_at)

    def on_imu(self, msg: Imu, at: float) -> None:
        self.last_imu = at
        o, g = msg.orientation, msg.angular_velocity
        self.fall_checker.update(at, (o.x, o.y, o.z, o.w), (g.x, g.y, g.z))

    def on_joint_states(self, msg: JointState, at: float) -> None:
        # a bus that repeats stale values is as silent as one that says nothing
        positions = np.asarray(msg.position)
        if self.last_joint_positions is None or len(positions) != len(self.last_joint_positions) or \
                not np.array_equal(positions, self.last_joint_positions) or msg.velocity.any():
            self.last_joints = at
        self.last_joint_positions = positions
        self.joint_names = list(msg.name)

    def on_paused(self, msg: Bool) -> None:
        self.bb.penalized = bool(msg.data)
        self.step()

    def on_walking_active(self, msg: Bool) -> None:
        self.walking_active_flag = bool(msg.data)

    def on_servo_data(self, msg: AdditionalServoData) -> None:
        limit = self.params.battery_low_v
        if limit <= 0 or not len(msg.voltage):
            return
        low = float(np.min(msg.voltage)) < limit
        if low and not self.battery_announced:
            self.speak(f"battery low: {float(np.min(msg.voltage)):.1f} volts", 2)
        self.battery_announced = low

    def on_servo_health(self, msg: ServoHealth) -> None:
        # a servo that stops answering keeps its last value in joint_states; the servo bus says which on servo_health
        missing = ",".join(msg.missing_servos)
        if missing != self.missing_servos:
            self.missing_servos = missing
            self.set_diagnostic("missing_servos", missing)
            self.step()

    def on_goals(self, source: GoalSource, trajectory: JointTrajectory) -> None:
        self.last_motion = self.now()
        if source is GoalSource.WALKING:
            self.last_walk_goal = self.last_motion
        if self.machine.state is HcmState.MOTOR_OFF:
            self.bb.motion_requested = True
        if passes(source, self.machine.state):
            self._forward(source, trajectory)

    def on_animation(self, msg: Animation) -> None:
        now = self.now()
        if msg.hcm:
            if self.own_goal is not None and passes(GoalSource.HCM_ANIMATION, self.machine.state):
                self._forward(GoalSource.HCM_ANIMATION, msg.position)
            return
        self.last_motion = now
        self.last_external_animation = now
        self.external_animation_over = bool(msg.last)
        if self.machine.state is HcmState.MOTOR_OFF:
            self.bb.motion_requested = True
        if self.machine.state in (HcmState.CONTROLLABLE, HcmState.WALKING) and not msg.last:
            self.step()  # -> ANIMATION_RUNNING at once, so this first frame already passes
        if passes(GoalSource.ANIMATION, self.machine.state):
            self._forward(GoalSource.ANIMATION, msg.position)

    def _forward(self, source: GoalSource, trajectory: JointTrajectory) -> None:
        if not trajectory.points:
            return
        point = trajectory.points[0]
        if len(point.effort) == len(trajectory.joint_names) and len(point.effort):
            # efforts of animation and recorder goals are torque switches (1 on, 0 off, -1 unchanged)
            switch = [(n, e) for n, e in zip(trajectory.joint_names, point.effort, strict=True) if e >= 0.0]
            if switch:
                self.torque_pub.publish(schemas.make(JointState, header=header(),
                                                     name=[n for n, _ in switch], effort=[e for _, e in switch]))
            # the goals go on without the switches; a new message, as the received one is shared (frozen)
            point = dataclasses.replace(point, effort=np.zeros(0))
            trajectory = dataclasses.replace(trajectory, points=[point, *trajectory.points[1:]])
        if len(point.positions):
            self.goals_pub.publish(trajectory)
        self.forwarded[source] += 1

    # -- the decision -------------------------------------------------------------------------------------
    def step(self) -> None:
        self.take_sensors()
        now = self.now()
        bb, p, checker = self.bb, self.params, self.fall_checker
        bb.now = now
        bb.hardware_ok = (now - self.last_imu < p.imu_timeout_s and now - self.last_joints < p.motor_timeout_s
                          and not self.missing_servos)
        bb.falling, bb.fallen, bb.leaning = checker.falling, checker.fallen, checker.leaning
        upright = math.radians(p.upright_deg)
        bb.upright = abs(checker.roll) < upright and abs(checker.pitch) < upright
        bb.record = p.record_mode
        bb.shutdown = self._shutdown_requested_at is not None
        bb.walking_active = self.walking_active_flag or now - self.last_walk_goal < 0.1
        bb.external_animation = not self.external_animation_over and now - self.last_external_animation < 0.5
        bb.idle_s = now - self.last_motion
        bb.fall_detection, bb.stand_up = p.fall_detection, p.stand_up
        bb.motor_off_after_s = p.motor_off_after_s
        bb.animation_busy = self.own_goal is not None
        changed = False
        for _ in range(3):  # follow immediate chains (e.g. a finished animation and a new condition)
            before = self.machine.state
            if not self.machine.step(bb):
                break
            changed = True
            if self.machine.state is not HcmState.MOTOR_OFF:
                bb.motion_requested = False
            self.log.info("%s -> %s (%s)%s", before.value, self.machine.state.value,
                          self.machine.history[-1].condition,
                          f" at sim {self.now():.2f} s" if self.clock.simulated else "")
            self.publish_state()  # every state of a chain goes out (FALLING -> FALLEN -> GETTING_UP)
        if changed:
            self.publish_graph()
            if self.machine.state is HcmState.HCM_OFF and self._shutdown_requested_at is not None:
                self.shutdown()

    # -- HcmActions -----------------------------------------------------------------------------------
    def play(self, animation: str) -> None:
        if self.own_goal is not None and not self.own_goal.done:
            self.own_goal = None  # the new HCM goal preempts the old one at the animation server
        goal = schemas.make(PlayAnimationGoal, animation=animation, hcm=True)
        handle: ClientGoal

        def on_verdict(h: ClientGoal) -> None:
            if not h.accepted:
                self.record_error(f"animation {animation!r} refused: {h.reason}")
                if self.own_goal is h:
                    self.own_goal = None

        def on_result(status: GoalStatus, _result: object) -> None:
            if self.own_goal is handle:
                self.own_goal = None
                if status is GoalStatus.ABORTED:
                    self.record_error(f"animation {animation!r} aborted")
            self.step()

        handle = self.animations.send_goal(goal, on_result=on_result, on_verdict=on_verdict, timeout=2.0)
        self.own_goal = handle
        self.bb.animation_busy = True

    def cancel_animation(self) -> None:
        if self.own_goal is not None:
            goal, self.own_goal = self.own_goal, None
            goal.request_cancel()

    def torque(self, enabled: bool) -> None:
        if not self.joint_names:
            return
        value = 1.0 if enabled else 0.0
        self.torque_pub.publish(schemas.make(JointState, header=header(),
                                             name=list(self.joint_names), effort=[value] * len(self.joint_names)))

    def speak(self, text: str, priority: int) -> None:
        self.speak_pub.publish(schemas.make(Speak, text=text, priority=priority))

    # -- outputs ------------------------------------------------------------------------------------------
    def publish_state(self) -> None:
        self.state_pub.publish(schemas.make(RobotControlState, state=PUBLISHED_VALUE[self.machine.state]))
        self.set_diagnostic("state", self.machine.state.value)

    def publish_graph(self) -> None:
        states, transitions = self.machine.graph()
        history = list(self.machine.history)
        self.graph_pub.publish(schemas.make(
            StateMachineGraph,
            header=header(), name="hcm", states=states,
            transition_from=[t[0] for t in transitions], transition_to=[t[1] for t in transitions],
            transition_condition=[t[2] for t in transitions], current=self.machine.state.value,
            history_states=[h.state.value for h in history],
            history_stamps=[schemas.stamp(h.wall_time) for h in history],
        ))

    def on_parameters_changed(self, changed: dict[str, Any]) -> None:
        self._apply_thresholds()
        self.machine.animations = self._animation_names()
        self.machine.penalty_torque_off = self.params.penalty_torque_off
        if "rate_hz" in changed:
            self.step_timer.set_rate(self.params.rate_hz)
        if "state_publish_hz" in changed:
            self.state_timer.set_rate(self.params.state_publish_hz)

    def _apply_thresholds(self) -> None:
        p = self.params
        self.fall_checker.thresholds = FallThresholds(
            gyro_pitch=p.falling_gyro_pitch, gyro_roll=p.falling_gyro_roll,
            no_return_pitch=math.radians(p.falling_no_return_pitch_deg),
            no_return_roll=math.radians(p.falling_no_return_roll_deg), smoothing=p.falling_smoothing_s,
            fallen_orientation=math.radians(p.fallen_orientation_deg), fallen_at_rest_gyro=p.fallen_at_rest_gyro)

    def _animation_names(self) -> dict[str, str]:
        p = self.params
        return {"walkready": p.anim_walkready, "falling_front": p.anim_falling_front,
                "falling_back": p.anim_falling_back, "falling_left": p.anim_falling_left,
                "falling_right": p.anim_falling_right, "stand_up_front": p.anim_stand_up_front,
                "stand_up_back": p.anim_stand_up_back, "turning_front": p.anim_turning_front,
                "penalty_in": p.anim_penalty_in,
                "penalty_out": p.anim_penalty_out, "shutdown": p.anim_shutdown}

    def request_shutdown(self) -> None:
        """First SHUTDOWN with its animation, then HCM_OFF, then the process ends (at most 4 s later)."""
        if self._shutdown_requested_at is not None:
            return
        self._shutdown_requested_at = self.now()
        self.step()
        # on the wall clock: a simulated clock stands still once the world has stopped
        deadline = threading.Timer(SHUTDOWN_DEADLINE_S, self.loop.call_soon, (self.shutdown,))
        deadline.daemon = True
        deadline.start()

    def on_shutdown(self) -> None:
        self.torque(False)
        self.state_pub.publish(schemas.make(RobotControlState, state=PUBLISHED_VALUE[HcmState.HCM_OFF]))




