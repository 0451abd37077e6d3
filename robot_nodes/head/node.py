"""The head node: what the behaviour wants to look at (head_mode) into head_motor_goals, which the HCM passes on while
the robot stands or walks (thesis HeadMode).

Modes: BALL_MODE tracks the ball while it is seen, looks where it was last seen for a moment when it is lost, then
searches with a sweep pattern; POST_MODE looks at the opponent goal (where it was seen, else where the own position
says it is, else searches for it); FIELD_FEATURES searches a wider, higher pattern; LOOK_DOWN, LOOK_FORWARD, LOOK_UP
hold fixed poses; DONT_MOVE sends nothing. BALL_GOAL_TRACKING and NON_FIELD_FEATURES are treated as BALL_MODE and
LOOK_UP. The node ticks only while it has something to do: not in DONT_MOVE, not while the HCM lets no head goal
through (falling, animations, penalty), and never faster than ``rate_hz``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

import robots
import schemas
from robot_nodes.ground_pose import OWN_HALF_DOC, OWN_HALVES, team_frame
from robot_nodes.head.geometry import PAN, TILT, HeadGeometry
from robot_nodes.head.pattern import SearchPattern
from robot_nodes.runtime import Node, header, param
from schemas.messages import BallRelative, GoalRelative, HeadMode, Position2D, RobotControlState
from schemas.std import JointState, JointTrajectory, JointTrajectoryPoint

# the HCM states whose head goals reach the motors (robot_nodes/hcm/joint_mutex.py: CONTROLLABLE, WALKING)
HEAD_STATES = (RobotControlState.CONTROLLABLE, RobotControlState.WALKING)
BALL_HEIGHT = 0.075  # m, the ball's centre above the ground (kid size)
GOAL_AIM_HEIGHT = 0.3  # m: look at the posts' lower part, so the goal line is in the image too
JUMP_M = 0.5  # a sighting this far from the tracked ball is a new ball position (kicked), not noise


@dataclass
class HeadParams:
    model: str = param("minibot", startup=True, doc="robot model; its URDF gives the head's limits and camera")
    urdf: str = param("", startup=True, doc="URDF to read instead of the model's")
    rate_hz: float = param(20.0, range=(1.0, 100.0), doc="head goals per second at most, while there is work")
    trunk_height: float = param(0.35, range=(0.1, 1.5), doc="base_link above the ground when standing, m")
    search_speed: float = param(3.0, range=(0.2, 8.0),
                                doc="rad/s of the head while searching (the camera sees at 10 Hz: slower misses less)")
    track_speed: float = param(5.0, range=(0.2, 8.0), doc="rad/s of the head while tracking")
    limit_margin_deg: float = param(5.0, range=(0.0, 30.0), doc="the head stays this far inside its joint limits")
    ball_search_pan_deg: float = param(95.0, range=(0.0, 180.0), doc="ball search sweeps this far to each side")
    ball_search_far_tilt_deg: float = param(-18.0, range=(-110.0, 70.0), doc="ball search: the far row's tilt")
    ball_search_near_tilt_deg: float = param(-55.0, range=(-110.0, 70.0), doc="ball search: the near row's tilt")
    field_search_pan_deg: float = param(120.0, range=(0.0, 180.0), doc="field features search: to each side")
    field_search_tilts_deg: str = param("-8,-30", doc="field features search: comma-separated row tilts")
    ball_lost_s: float = param(0.7, range=(0.1, 10.0), doc="no ball seen this long: it is lost")
    last_seen_look_s: float = param(1.0, range=(0.0, 10.0),
                                    doc="a lost ball: look where it was last seen this long before searching")
    goal_seen_s: float = param(1.0, range=(0.1, 10.0), doc="a goal seen this recently is looked at directly")
    position_age_s: float = param(2.0, range=(0.1, 30.0), doc="the own position is trusted this long")
    field_length: float = param(9.0, range=(1.0, 30.0), doc="goal line to goal line (the opponent goal is at +x/2)")
    own_half: str = param("-x", choices=OWN_HALVES, doc=OWN_HALF_DOC)
    look_forward_tilt_deg: float = param(-20.0, range=(-110.0, 70.0), doc="LOOK_FORWARD's tilt")
    look_down_tilt_deg: float = param(-65.0, range=(-110.0, 70.0), doc="LOOK_DOWN's tilt")
    look_up_tilt_deg: float = param(0.0, range=(-110.0, 70.0), doc="LOOK_UP's tilt")
    ball_below_centre_deg: float = param(10.0, range=(0.0, 25.0),
                                         doc="tracking keeps the ball this far below the image centre: more field "
                                             "in view, and the lens stays clear of the own shoulders")
    ball_smoothing: float = param(0.4, range=(0.05, 1.0),
                                  doc="weight of a new sighting in the tracked ball position (1: no smoothing)")
    reached_deg: float = param(4.0, range=(0.5, 20.0), doc="a pattern point counts as reached this close")
    resend_deg: float = param(2.0, range=(0.0, 20.0), doc="tracking sends a new goal when it moved this much")


class HeadNode(Node):
    """Points the head as head_mode asks: ball search and tracking, the goal, fixed looks."""

    name = "head"
    Params = HeadParams

    def setup(self) -> None:
        p = self.params
        self.geometry = HeadGeometry.from_urdf(Path(p.urdf) if p.urdf else robots.urdf(p.model))
        self.mode = HeadMode.BALL_MODE
        self.mode_since = self.now()
        self.robot_state: int | None = None
        self.ball: tuple[float, float] | None = None  # last seen, base_footprint
        self.ball_seen_at = -math.inf
        self.goal: tuple[float, float] | None = None  # centre of the last seen goal, base_footprint
        self.goal_seen_at = -math.inf
        self.position: tuple[float, float, float] | None = None
        self.position_at = -math.inf
        self.present: tuple[float, float] | None = None  # (pan, tilt) measured
        self.sent: tuple[float, float] | None = None
        self.sent_at = -math.inf
        self.pattern_index: int | None = None
        self.pattern_name = ""
        self.goals_sent = 0
        self._build_patterns()
        self.goals_pub = self.publisher("head_motor_goals")
        self.subscribe("head_mode", self.on_head_mode)
        self.subscribe("robot_state", self.on_robot_state)
        self.subscribe("ball_relative", self.on_ball)
        self.subscribe("goal_relative", self.on_goal)
        self.subscribe("position", self.on_position)
        self.joints = self.keep_latest("joint_states")  # read by the tick: 100 messages a second never wake it
        self.tick_timer = self.timer(self.tick, rate_hz=p.rate_hz, name="head")
        self._update_activity()

    # -- inputs -------------------------------------------------------------------------------------------
    def on_head_mode(self, msg: HeadMode) -> None:
        mode = int(msg.head_mode)
        if mode != self.mode:
            self.mode = mode
            self.mode_since = self.now()
            self.pattern_index = None
            self.sent = None  # a new mode sends its first goal at once
            self.set_diagnostic("mode", mode)
        self._update_activity()

    def on_robot_state(self, msg: RobotControlState) -> None:
        self.robot_state = int(msg.state)
        self._update_activity()

    def on_ball(self, msg: BallRelative) -> None:
        seen = (float(msg.ball_relative.x), float(msg.ball_relative.y))
        now = self.now()
        # a noisy vision makes a jittering head: smooth while the ball stays where it was, jump where it moved
        old = self.ball
        if old is not None and now - self.ball_seen_at < self.params.ball_lost_s and \
                math.hypot(seen[0] - old[0], seen[1] - old[1]) < JUMP_M:
            w = self.params.ball_smoothing
            seen = (old[0] + w * (seen[0] - old[0]), old[1] + w * (seen[1] - old[1]))
        self.ball = seen
        self.ball_seen_at = now

    def on_goal(self, msg: GoalRelative) -> None:
        self.goal = ((msg.left_post.x + msg.right_post.x) / 2, (msg.left_post.y + msg.right_post.y) / 2)
        self.goal_seen_at = self.now()

    def on_position(self, msg: Position2D) -> None:
        self.position = team_frame(float(msg.pose.x), float(msg.pose.y), float(msg.pose.theta), self.params.own_half)
        self.position_at = self.now()

    def _head_position(self) -> tuple[float, float] | None:
        msg: JointState | None = self.joints.message
        if msg is None:
            return self.present
        names = list(msg.name)
        if PAN in names and TILT in names:
            self.present = (float(msg.position[names.index(PAN)]), float(msg.position[names.index(TILT)]))
        return self.present

    def on_parameters_changed(self, changed: dict[str, Any]) -> None:
        if "rate_hz" in changed:
            self.tick_timer.set_rate(self.params.rate_hz)
        self._build_patterns()
        self.pattern_index = None

    # -- when to work -------------------------------------------------------------------------------------
    def _update_activity(self) -> None:
        """Ticks only when head goals are wanted and would pass the HCM."""
        active = self.mode != HeadMode.DONT_MOVE and self.robot_state in HEAD_STATES
        if active and not self.tick_timer.active:
            self.sent = None  # the head may have been moved meanwhile (an animation): send again
            self.pattern_index = None
            self.tick_timer.resume()
        elif not active and self.tick_timer.active:
            self.tick_timer.pause()
        self.set_diagnostic("active", active)

    # -- the decision -------------------------------------------------------------------------------------
    def tick(self) -> None:
        now = self.now()
        p = self.params
        mode = self.mode
        if mode in (HeadMode.BALL_MODE, HeadMode.BALL_GOAL_TRACKING):
            self._ball_mode(now)
        elif mode == HeadMode.POST_MODE:
            self._goal_mode(now)
        elif mode == HeadMode.FIELD_FEATURES:
            self._search("field", p.search_speed)
        elif mode == HeadMode.LOOK_DOWN:
            self._look(0.0, math.radians(p.look_down_tilt_deg), p.track_speed)
        elif mode == HeadMode.LOOK_FORWARD:
            self._look(0.0, math.radians(p.look_forward_tilt_deg), p.track_speed)
        else:  # LOOK_UP, NON_FIELD_FEATURES, and a mode this node does not know
            self._look(0.0, math.radians(p.look_up_tilt_deg), p.track_speed)

    def _ball_mode(self, now: float) -> None:
        p = self.params
        since_seen = now - self.ball_seen_at
        if self.ball is not None and since_seen < p.ball_lost_s + p.last_seen_look_s:
            self.pattern_index = None
            # tracking, and for a moment after a loss: where it was last seen (kicked balls, false negatives)
            pan, tilt = self.geometry.aim(self.ball[0], self.ball[1], BALL_HEIGHT, p.trunk_height)
            self._look(pan, tilt + self.geometry.tilt_sign * math.radians(p.ball_below_centre_deg), p.track_speed)
            self.set_diagnostic("doing", "tracking ball" if since_seen < p.ball_lost_s else "last seen ball")
            return
        self._search("ball", p.search_speed)
        self.set_diagnostic("doing", "ball search")

    def _goal_mode(self, now: float) -> None:
        p = self.params
        if self.goal is not None and now - self.goal_seen_at < p.goal_seen_s:
            self._look_at(self.goal[0], self.goal[1], GOAL_AIM_HEIGHT, p.track_speed)
            return
        if self.position is not None and now - self.position_at < p.position_age_s:
            x, y, theta = self.position
            gx, gy = p.field_length / 2 - x, -y  # the opponent goal's centre (team frame) from here
            c, s = math.cos(theta), math.sin(theta)
            self._look_at(c * gx + s * gy, -s * gx + c * gy, GOAL_AIM_HEIGHT, p.track_speed)
            return
        self._search("field", p.search_speed)

    # -- actions ------------------------------------------------------------------------------------------
    def _look_at(self, x: float, y: float, z: float, speed: float) -> None:
        pan, tilt = self.geometry.aim(x, y, z, self.params.trunk_height)
        self._look(pan, tilt, speed)

    def _look(self, pan: float, tilt: float, speed: float) -> None:
        """Sends the goal if it differs from the last one sent by more than resend_deg (or every second)."""
        pan, tilt = self.geometry.clamp(pan, tilt, math.radians(self.params.limit_margin_deg))
        now = self.now()
        if self.sent is not None and now - self.sent_at < 1.0 and \
                math.hypot(pan - self.sent[0], tilt - self.sent[1]) < math.radians(self.params.resend_deg):
            return
        self.sent, self.sent_at = (pan, tilt), now
        point = schemas.make(JointTrajectoryPoint, positions=np.array([pan, tilt]), velocities=np.array([speed, speed]))
        self.goals_pub.publish(schemas.make(JointTrajectory, header=header(), joint_names=[PAN, TILT], points=[point]))
        self.goals_sent += 1

    def _search(self, name: str, speed: float) -> None:
        pattern = self.patterns[name]
        here = self._head_position()
        if self.pattern_index is None or self.pattern_name != name:
            self.pattern_name = name
            self.pattern_index = pattern.nearest(*here) if here is not None else 0
            self.sent = None
        target = pattern.points[self.pattern_index]
        reached = here is not None and math.hypot(here[0] - target[0], here[1] - target[1]) < \
            math.radians(self.params.reached_deg)
        if reached:
            self.pattern_index = pattern.next(self.pattern_index)
            target = pattern.points[self.pattern_index]
        self._look(*target, speed)

    def _build_patterns(self) -> None:
        p = self.params
        margin = math.radians(p.limit_margin_deg)
        lo, hi = self.geometry.pan_limits

        def pan_within(deg: float) -> float:
            return min(math.radians(deg), hi - margin, -(lo + margin))

        def tilt(deg: float) -> float:
            return self.geometry.clamp(0.0, math.radians(deg), margin)[1]

        try:
            field_tilts = tuple(tilt(float(t)) for t in p.field_search_tilts_deg.split(",") if t.strip())
        except ValueError:
            self.record_error(f"field_search_tilts_deg {p.field_search_tilts_deg!r}: not comma-separated numbers")
            field_tilts = (tilt(-8.0), tilt(-30.0))
        self.patterns = {
            "ball": SearchPattern.sweep(pan_within(p.ball_search_pan_deg),
                                        (tilt(p.ball_search_far_tilt_deg), tilt(p.ball_search_near_tilt_deg))),
            "field": SearchPattern.sweep(pan_within(p.field_search_pan_deg), field_tilts or (tilt(-8.0),)),
        }
