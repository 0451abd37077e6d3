"""The kick node: the Kick action (thesis) as a server. Given where the ball is and where it should go, it picks the
foot from the ball's side, walks the last small steps until the ball lies in front of that foot and the robot faces the
kick direction, stands still and looks once more, plays the kick animation through the HCM, and reports.

While it runs a goal it alone sends cmd_vel (the behaviour waits for its result). A goal is rejected with the reason
when the ball is farther than ``max_ball_distance`` (walk there first) or the HCM does not let the robot move; it
is aborted when the ball is lost, the robot falls, the HCM stops the animation, or it takes longer than
``timeout_s``. Success: the kick animation played to its end, the robot is still standing, and no sighting in the next
``verify_s`` shows the ball still where it lay.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import Any

import schemas
from robot_nodes.ground_pose import GroundPose, heading, wrap
from robot_nodes.kick.approach import BallTrack, KickSpot, choose_foot, error, stand_pose, walk_command
from robot_nodes.runtime import GoalStatus, Node, ServerGoal, param
from schemas.messages import (
    BallRelative,
    KickFeedback,
    KickGoal,
    KickResult,
    PlayAnimationGoal,
    RobotControlState,
)
from schemas.std import Bool, Odometry, Twist, Vector3
from wire.actions import ClientGoal

MOVABLE = (RobotControlState.CONTROLLABLE, RobotControlState.WALKING)
DOWN = (RobotControlState.FALLING, RobotControlState.FALLEN, RobotControlState.GETTING_UP)


class Phase(enum.Enum):
    IDLE = "idle"  # no goal
    APPROACH = "approach"  # small steps until the ball is at the kick spot
    STOPPING = "stopping"  # the walk finishes its steps
    SETTLE = "settle"  # standing, the ball's position is measured once more
    KICKING = "kicking"  # the animation plays
    VERIFY = "verify"  # did the ball go?


@dataclass
class KickParams:
    rate_hz: float = param(20.0, range=(2.0, 100.0), doc="approach steps per second while a goal runs")
    spot_x: float = param(0.18, range=(0.05, 0.4),
                          doc="the ball's centre this far ahead of base_footprint, m (nearer, it touches the toe)")
    spot_y: float = param(0.06, range=(0.0, 0.2), doc="...and this far to the kicking foot's side, m")
    tolerance_x: float = param(0.025, range=(0.005, 0.2), doc="close enough to the spot, forward, m")
    tolerance_y: float = param(0.02, range=(0.005, 0.2), doc="close enough to the spot, sideways, m")
    tolerance_yaw_deg: float = param(6.0, range=(1.0, 45.0), doc="facing the kick direction close enough, deg")
    max_ball_distance: float = param(1.0, range=(0.2, 5.0), doc="goals with the ball farther away are rejected, m")
    approach_speed: float = param(0.08, range=(0.01, 0.3), doc="fastest approach step, m/s")
    approach_turn: float = param(0.25, range=(0.05, 1.5), doc="fastest approach turn, rad/s")
    approach_gain: float = param(1.0, range=(0.1, 5.0),
                                 doc="walk command per metre (radian) still to go, 1/s: a step (0.5 s) covers half")
    settle_sightings: int = param(5, range=(1, 50),
                                  doc="standing still, average this many new sightings of the ball before the strike")
    verify_s: float = param(0.8, range=(0.0, 5.0),
                            doc="after the strike, a sighting this soon near where the ball lay means it was missed")
    ball_lost_s: float = param(3.0, range=(0.5, 30.0), doc="no sighting of the ball this long aborts the kick")
    timeout_s: float = param(25.0, range=(2.0, 120.0), doc="a kick that takes longer is aborted")
    max_tries: int = param(4, range=(1, 20), doc="how often the approach may start over after settling")
    hurry_tolerance: float = param(1.5, range=(1.0, 3.0),
                                   doc="a goal marked unstable (a rival at the ball): close enough at this multiple "
                                       "of the tolerances")
    hurry_settle_sightings: int = param(2, range=(1, 50), doc="...and strike after this many sightings standing")
    animation_left: str = param("kick_left", doc="animation of a kick with the left foot")
    animation_right: str = param("kick_right", doc="animation of a kick with the right foot")


class KickNode(Node):
    """Kick action server: approach, strike, report."""

    name = "kick"
    Params = KickParams

    def setup(self) -> None:
        self.robot_state: int | None = None
        self.walking = False
        self.odometry: GroundPose | None = None
        self.ball = BallTrack()
        self.goal: ServerGoal | None = None
        self.phase = Phase.IDLE
        self.phase_since = 0.0
        self.started = 0.0
        self.direction = 0.0  # the kick direction in the odometry frame
        self.foot = "left"
        self.tries = 0
        self.hurry = False
        self.kicks = 0
        self.last_result = ""  # why the last goal ended, as its diagnostics say
        self.animation_goal: ClientGoal | None = None
        self.struck_at: tuple[float, float] | None = None  # where the ball lay when the strike began (odometry)
        self.cmd_pub = self.publisher("cmd_vel")
        self.server = self.action_server("kick", self.on_goal, self.on_cancel, self.on_preempt)
        self.animations = self.action_client("animation")
        self.subscribe("ball_relative", self.on_ball)
        self.subscribe("walk_odometry", self.on_odometry)
        self.subscribe("robot_state", self.on_robot_state)
        self.subscribe("walking_active", self.on_walking_active)
        self.tick_timer = self.timer(self.tick, rate_hz=self.params.rate_hz, name="kick")
        self.tick_timer.pause()  # ticks only while a goal runs

    @property
    def spot(self) -> KickSpot:
        p = self.params
        return KickSpot(p.spot_x, p.spot_y, p.tolerance_x, p.tolerance_y, math.radians(p.tolerance_yaw_deg))

    # -- inputs -------------------------------------------------------------------------------------------
    def on_odometry(self, msg: Odometry) -> None:
        q = msg.pose.pose.orientation
        self.odometry = GroundPose(float(msg.pose.pose.position.x), float(msg.pose.pose.position.y),
                                   heading(q.x, q.y, q.z, q.w))

    def on_ball(self, msg: BallRelative) -> None:
        if self.odometry is None or self.goal is None or self.phase is Phase.KICKING:
            return
        x, y = self.odometry.absolute(float(msg.ball_relative.x), float(msg.ball_relative.y))
        self.ball.add(self.now(), x, y)

    def on_robot_state(self, msg: RobotControlState) -> None:
        self.robot_state = int(msg.state)

    def on_walking_active(self, msg: Bool) -> None:
        self.walking = bool(msg.data)

    def on_parameters_changed(self, changed: dict[str, Any]) -> None:
        if "rate_hz" in changed:
            self.tick_timer.set_rate(self.params.rate_hz)

    # -- the action ---------------------------------------------------------------------------------------
    def on_goal(self, handle: ServerGoal) -> str | None:
        goal: KickGoal = handle.goal
        bx, by = float(goal.ball_position.x), float(goal.ball_position.y)
        q = goal.kick_direction
        direction = heading(q.x, q.y, q.z, q.w)
        if not all(math.isfinite(v) for v in (bx, by, direction)):
            return "ball position and kick direction must be finite"
        if math.hypot(bx, by) > self.params.max_ball_distance:
            return (f"the ball is {math.hypot(bx, by):.2f} m away, more than max_ball_distance "
                    f"{self.params.max_ball_distance} m: walk closer first")
        if self.robot_state not in MOVABLE:
            return f"the HCM does not let the robot move (robot_state {self.robot_state})"
        if self.odometry is None:
            return "no walk_odometry yet (is the walking node running?)"
        if self.goal is not None and not self.goal.done:
            self._stop_animation()
        # the goal's ball and direction are relative to the robot now: keep them in the odometry frame
        self.ball = BallTrack()
        here = self.odometry
        self.ball.add(self.now(), *here.absolute(bx, by))
        self.direction = wrap(here.yaw + direction)
        self.foot = choose_foot(here, here.absolute(bx, by), self.direction)
        self.hurry = bool(goal.unstable)  # the thesis's flag: strike sooner, less exactly (a rival is near)
        self.goal = handle
        self.tries = 0
        self.started = self.now()
        self._enter(Phase.APPROACH)
        self.tick_timer.resume()
        self.log.info("kick with the %s foot: ball at (%.2f, %.2f), direction %.0f deg%s", self.foot, bx, by,
                      math.degrees(direction), ", in a hurry" if self.hurry else "")
        return None

    def on_cancel(self, handle: ServerGoal) -> None:
        self._finish(handle, GoalStatus.CANCELED, KickResult.RESULT_ABORTED, "canceled")

    def on_preempt(self, handle: ServerGoal) -> None:
        self._walk(0.0, 0.0, 0.0)  # the new goal starts from a standing robot's odometry

    # -- the approach and the strike ---------------------------------------------------------------------
    def tick(self) -> None:
        goal = self.goal
        if goal is None or goal.done:
            self.tick_timer.pause()
            return
        now = self.now()
        p = self.params
        if now - self.started > p.timeout_s:
            self._finish(goal, GoalStatus.ABORTED, KickResult.RESULT_ABORTED, f"not done within {p.timeout_s} s")
            return
        if self.robot_state in DOWN or self.robot_state in (RobotControlState.PENALTY,
                                                              RobotControlState.PENALTY_ANIMATION):
            self._finish(goal, GoalStatus.ABORTED, KickResult.RESULT_ABORTED,
                         f"the robot cannot kick now (robot_state {self.robot_state})")
            return
        if self.phase is Phase.KICKING:
            return  # the animation's result moves on
        if self.phase is Phase.VERIFY:
            if self.ball.count_since(self.phase_since) and self._ball_still_there():
                self._finish(goal, GoalStatus.ABORTED, KickResult.RESULT_ABORTED,
                             "the ball did not go: seen within 0.25 m of its spot after the strike")
            elif now - self.phase_since >= p.verify_s:
                self.kicks += 1
                self.set_diagnostic("kicks", self.kicks)
                self._finish(goal, GoalStatus.SUCCEEDED, KickResult.RESULT_SUCCESS, "kicked")
            return
        if now - self.ball.last_seen() > p.ball_lost_s:
            self._finish(goal, GoalStatus.ABORTED, KickResult.RESULT_ABORTED, f"ball not seen for {p.ball_lost_s} s")
            return
        # standing still to settle, only the sightings since then count: taken from one place, they average well
        robot = self.odometry
        ball = self.ball.estimate(self.phase_since if self.phase is Phase.SETTLE else -math.inf)
        assert robot is not None and ball is not None
        if math.hypot(*robot.relative(*ball)) > p.max_ball_distance + 0.3:
            self._finish(goal, GoalStatus.ABORTED, KickResult.RESULT_ABORTED, "the ball went away")
            return
        target = stand_pose(ball, self.direction, self.foot, self.spot)
        err = error(robot, target)
        self.set_diagnostic("error", f"forward {err.forward:+.3f} left {err.left:+.3f} turn "
                                     f"{math.degrees(err.turn):+.1f}")
        # a goal in a hurry (its unstable flag) is close enough farther off and settles on fewer sightings
        scale, settle_sightings = ((p.hurry_tolerance, p.hurry_settle_sightings) if self.hurry else
                                   (1.0, p.settle_sightings))
        if self.phase is Phase.APPROACH:
            if err.within(self.spot, scale):
                self._walk(0.0, 0.0, 0.0)
                self._enter(Phase.STOPPING)
                return
            ahead = robot.relative(*ball)[0]
            self._walk(*walk_command(err, ahead, p.approach_speed, p.approach_turn, p.approach_gain))
            self._feedback(min(45.0, 45.0 * 0.1 / max(0.1, math.hypot(err.forward, err.left))))
        elif self.phase is Phase.STOPPING:
            if not self.walking and self.robot_state == RobotControlState.CONTROLLABLE:
                self._enter(Phase.SETTLE)
        elif self.phase is Phase.SETTLE:
            if self.ball.count_since(self.phase_since) < settle_sightings:
                return
            if err.within(self.spot, 1.25 * scale):
                self._strike()
            elif self.tries + 1 >= p.max_tries:
                self._finish(goal, GoalStatus.ABORTED, KickResult.RESULT_ABORTED,
                             f"could not get the ball to the kick spot in {p.max_tries} tries")
            else:
                self.tries += 1
                self.log.info("kick: not at the spot after settling (%s), approach again", self._diag_values["error"])
                self._enter(Phase.APPROACH)

    def _strike(self) -> None:
        p = self.params
        self.struck_at = self.ball.estimate(self.phase_since)
        where = ""
        if self.odometry is not None and self.struck_at is not None:
            x, y = self.odometry.relative(*self.struck_at)
            where = f"({x:.3f}, {y:.3f})"
            self.set_diagnostic("strike_ball", f"{where} {self.foot}")
        name = p.animation_left if self.foot == "left" else p.animation_right
        # where the ball lay: what a kick that "did not go" is read against (the spot is spot_x, +-spot_y)
        self.log.info("strike with the %s foot %.1f s after the goal came (%d approaches), ball at %s", self.foot,
                      self.now() - self.started, self.tries + 1, where or "unknown")
        self._enter(Phase.KICKING)
        self._feedback(50.0)
        goal = self.goal

        def on_result(status: GoalStatus, result: Any) -> None:
            if goal is None or goal.done or self.goal is not goal:
                return
            standing = self.robot_state not in DOWN
            if status is GoalStatus.SUCCEEDED and standing:
                self._enter(Phase.VERIFY)  # the next sightings tell whether the ball went
            else:
                why = str(getattr(result, "message", "") or status.name)
                self._finish(goal, GoalStatus.ABORTED, KickResult.RESULT_ABORTED,
                             f"kick animation {name}: {why}{'' if standing else ', the robot fell'}")

        def on_verdict(handle: ClientGoal) -> None:
            if not handle.accepted and goal is not None and not goal.done:
                self._finish(goal, GoalStatus.ABORTED, KickResult.RESULT_ABORTED,
                             f"kick animation {name} refused: {handle.reason}")

        self.animation_goal = self.animations.send_goal(
            schemas.make(PlayAnimationGoal, animation=name, hcm=False),
            on_feedback=lambda fb: self._feedback(50.0 + fb.percent_done / 2.0),
            on_result=on_result, on_verdict=on_verdict, timeout=2.0)

    # -- helpers ------------------------------------------------------------------------------------------
    def _ball_still_there(self) -> bool:
        """A sighting since the strike within 0.25 m of where the ball lay before it."""
        before = self.struck_at
        return before is not None and any(math.hypot(x - before[0], y - before[1]) < 0.25
                                          for t, x, y in self.ball.sightings if t >= self.phase_since)

    def _enter(self, phase: Phase) -> None:
        self.log.debug("kick phase %s after %.1f s", phase.value, self.now() - self.started)
        self.phase = phase
        self.phase_since = self.now()
        self.set_diagnostic("phase", phase.value)

    def _walk(self, vx: float, vy: float, vyaw: float) -> None:
        self.cmd_pub.publish(schemas.make(Twist, linear=Vector3(x=vx, y=vy, z=0.0),
                                          angular=Vector3(x=0.0, y=0.0, z=vyaw)))

    def _feedback(self, percent: float) -> None:
        if self.goal is not None:
            self.goal.publish_feedback(schemas.make(KickFeedback, percent_done=float(percent)))

    def _stop_animation(self) -> None:
        if self.animation_goal is not None and not self.animation_goal.done:
            self.animation_goal.request_cancel()
        self.animation_goal = None

    def _finish(self, goal: ServerGoal, status: GoalStatus, result: int, why: str) -> None:
        if self.phase is not Phase.KICKING:
            self._walk(0.0, 0.0, 0.0)
        elif status is not GoalStatus.SUCCEEDED:
            self._stop_animation()
        outcome = schemas.make(KickResult, result=result)
        {GoalStatus.SUCCEEDED: goal.succeed, GoalStatus.CANCELED: goal.canceled}.get(status, goal.abort)(outcome)
        self.last_result = why
        self.set_diagnostic("last_result", why)
        self.log.info("kick %s: %s", status.name.lower(), why)
        if self.goal is goal:
            self.goal = None
            self._enter(Phase.IDLE)
            self.tick_timer.pause()
