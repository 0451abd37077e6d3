"""What a robot tells an HSL GameController in its RGrt v4 status packet: fallen (from the HCM), its pose in the
field frame (localization) and the ball it sees, with the ball's age.

Kept apart from the receiver node so the arithmetic (metres -> mm, the age of the newest sighting) is one small
thing with its own test. The packet wants the pose in the team's frame: origin at the centre mark, +x towards the
goal the robot attacks, +y to the left; a localization whose `position` has the team defend +x (``own_half``,
as the simulated match's stand-ins for the away team) is turned into it.
"""

from __future__ import annotations

from robot_nodes.ground_pose import team_frame
from schemas.messages import BallRelative, Position2D, RobotControlState
from wire.gamecontroller.game_data import StatusPacket

# HCM states in which the robot is on the ground (GETTING_UP: still down until it stands)
FALLEN_STATES = frozenset({RobotControlState.FALLING, RobotControlState.FALLEN, RobotControlState.GETTING_UP})
FALLEN_UNKNOWN = 255
STATUS_RATE_HZ = (0.5, 2.0)  # the HSL GameController's README: every robot between 0.5 and 2 Hz


class RobotStatus:
    """The newest HCM state, pose and ball sighting, and the status packet they make."""

    def __init__(self, own_half: str = "-x") -> None:
        self.own_half = own_half
        self.hcm_state: int | None = None
        self.pose: tuple[float, float, float] | None = None  # m, m, rad
        self.ball: tuple[float, float] | None = None  # m, relative to the robot
        self.ball_seen_at: float | None = None  # the node's clock

    def on_robot_state(self, msg: RobotControlState) -> None:
        self.hcm_state = int(msg.state)

    def on_position(self, msg: Position2D) -> None:
        self.pose = team_frame(float(msg.pose.x), float(msg.pose.y), float(msg.pose.theta), self.own_half)

    def on_ball(self, msg: BallRelative, now: float) -> None:
        """A sighting counts when its confidence is above 0 (the stand-ins say 0 when they see no ball)."""
        if msg.confidence > 0:
            self.ball = (float(msg.ball_relative.x), float(msg.ball_relative.y))
            self.ball_seen_at = now

    def packet(self, team: int, player: int, now: float) -> StatusPacket:
        fallen = FALLEN_UNKNOWN if self.hcm_state is None else int(self.hcm_state in FALLEN_STATES)
        x, y, theta = self.pose if self.pose is not None else (0.0, 0.0, 0.0)
        if self.ball is None or self.ball_seen_at is None:
            age, ball = -1.0, (0.0, 0.0)
        else:
            age, ball = max(0.0, now - self.ball_seen_at), (self.ball[0] * 1000.0, self.ball[1] * 1000.0)
        return StatusPacket(team=team, player=player, fallen=fallen, pose_mm=(x * 1000.0, y * 1000.0, theta),
                            ball_age_s=age, ball_mm=ball)


def status_rate_hz(asked_hz: float) -> float:
    """The asked return rate, held within what the HSL GameController allows."""
    lo, hi = STATUS_RATE_HZ
    return min(hi, max(lo, asked_hz))
