"""What the behaviour believes about the game: its own pose (the last position, carried on by walk odometry while the
localization is lost), the ball (its own sighting, else a teammate's), and the teammates as team_data tells them."""

from __future__ import annotations

import math
from dataclasses import dataclass

from robot_nodes.ground_pose import GroundPose, team_frame, wrap
from schemas.messages import BallRelative, Position2D, TeamData

NOT_TOLD = 255  # team_data's "the teammate did not say"
PENALIZED_STATES = frozenset({7, 8, 14})  # RobotControlState PENALTY, PENALTY_ANIMATION, PICKED_UP


@dataclass(frozen=True)
class Teammate:
    player: int
    role: int | None
    state: int | None
    pose: GroundPose | None
    ball: tuple[float, float] | None  # on the field
    time_to_ball: float | None
    age: float

    @property
    def penalized(self) -> bool:
        return self.state in PENALIZED_STATES


class WorldModel:
    """Fed by the node's subscriptions; every answer takes ``now`` (monotonic seconds)."""

    def __init__(self, ball_timeout_s: float = 3.0, position_timeout_s: float = 10.0, mate_timeout_s: float = 3.0,
                 own_half: str = "-x") -> None:
        self.ball_timeout_s = ball_timeout_s
        self.position_timeout_s = position_timeout_s
        self.mate_timeout_s = mate_timeout_s
        self.fix_weight = 0.3  # of a new position fix against the pose carried on by odometry
        self.jump_m = 1.0  # a fix this far off is taken as it is (the robot was carried, or the filter was wrong)
        self._fix: GroundPose | None = None
        self._fix_at = -math.inf
        self._fix_odometry: GroundPose | None = None  # the odometry when the fix came
        self.odometry: GroundPose | None = None
        self.ball_relative: tuple[float, float] | None = None
        self.ball_field: tuple[float, float] | None = None
        self.ball_at = -math.inf
        self.mates: list[Teammate] = []
        self.mates_at = -math.inf
        self.own_half = own_half  # the half the team defends in the frame positions come in (ground_pose.team_frame)

    # -- inputs -------------------------------------------------------------------------------------------
    def on_position(self, msg: Position2D, now: float) -> None:
        """A new fix, blended into the odometry-carried pose (a complementary filter: the localization's noise
        averages out over a few fixes, its drift-free mean wins in the end)."""
        fix = GroundPose(*team_frame(float(msg.pose.x), float(msg.pose.y), float(msg.pose.theta), self.own_half))
        here = self.pose(now)
        if here is not None and math.hypot(fix.x - here.x, fix.y - here.y) < self.jump_m:
            a = self.fix_weight
            turn = wrap(fix.yaw - here.yaw)
            fix = GroundPose(here.x + a * (fix.x - here.x), here.y + a * (fix.y - here.y), here.yaw + a * turn)
        self._fix = fix
        self._fix_at = now
        self._fix_odometry = self.odometry

    def on_odometry(self, x: float, y: float, theta: float) -> None:
        self.odometry = GroundPose(x, y, theta)

    def on_ball(self, msg: BallRelative, now: float) -> None:
        self.ball_relative = (float(msg.ball_relative.x), float(msg.ball_relative.y))
        self.ball_at = now
        pose = self.pose(now)
        self.ball_field = pose.absolute(*self.ball_relative) if pose is not None else None

    def on_team_data(self, msg: TeamData, now: float) -> None:
        mates = []
        for i, player in enumerate(msg.robot_ids):
            position = msg.robot_positions[i]
            pose = GroundPose(*team_frame(float(position.pose.x), float(position.pose.y), float(position.pose.theta),
                                          self.own_half)) if position.confidence > 0 else None
            ball = msg.ball_relative[i]
            ball_field = pose.absolute(float(ball.pose.x), float(ball.pose.y)) if pose is not None and \
                ball.confidence > 0 else None
            time_to_ball = float(msg.time_to_position_at_ball[i])
            mates.append(Teammate(
                player=int(player), role=None if msg.role[i] == NOT_TOLD else int(msg.role[i]),
                state=None if msg.state[i] == NOT_TOLD else int(msg.state[i]), pose=pose, ball=ball_field,
                time_to_ball=time_to_ball if math.isfinite(time_to_ball) else None, age=float(msg.age[i])))
        self.mates = mates
        self.mates_at = now

    # -- beliefs ------------------------------------------------------------------------------------------
    def pose(self, now: float) -> GroundPose | None:
        """The last position fix, moved on by what the walk odometry measured since; None when too old."""
        fix = self._fix
        if fix is None or now - self._fix_at > self.position_timeout_s:
            return None
        then, odo = self._fix_odometry, self.odometry
        if then is None or odo is None or odo is then:
            return fix
        dx, dy = then.relative(odo.x, odo.y)  # travelled since the fix, in the robot's frame then
        x, y = fix.absolute(dx, dy)
        return GroundPose(x, y, fix.yaw + (odo.yaw - then.yaw))

    def position_fresh(self, now: float, within: float = 1.0) -> bool:
        return now - self._fix_at <= within

    def sees_ball(self, now: float) -> bool:
        return now - self.ball_at <= self.ball_timeout_s

    def ball(self, now: float) -> tuple[float, float] | None:
        """The ball on the field: the own sighting if recent, else the freshest teammate's."""
        if self.sees_ball(now) and self.ball_field is not None:
            return self.ball_field
        seen = [m for m in self.teammates(now) if m.ball is not None and not m.penalized]
        if seen:
            return min(seen, key=lambda m: m.age).ball
        return None

    def ball_from_me(self, now: float) -> tuple[float, float] | None:
        """The ball relative to the robot: its own sighting, else the team's ball seen from its pose."""
        if self.sees_ball(now) and self.ball_relative is not None:
            # the sighting moved on by the odometry is not needed: the ball is seen at 10 Hz while tracked
            return self.ball_relative
        ball, pose = self.ball(now), self.pose(now)
        if ball is None or pose is None:
            return None
        return pose.relative(*ball)

    def teammates(self, now: float) -> list[Teammate]:
        """Teammates heard recently (team_data's own age plus the time since it came)."""
        extra = now - self.mates_at
        return [m for m in self.mates if m.age + extra <= self.mate_timeout_s]
