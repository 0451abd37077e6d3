"""What one robot tells its teammates, in SI units: the common form both team-message codecs encode."""

from __future__ import annotations

from dataclasses import dataclass, field

# RobotControlState numbers (schemas/humanoid_league_msgs/msg/RobotControlState.msg) the codecs map
HCM_CONTROLLABLE = 0
HCM_STARTUP = 5
HCM_SHUTDOWN = 6
HCM_PENALTY = 7
HCM_PENALTY_ANIMATION = 8
HCM_RECORD = 9
HCM_PICKED_UP = 14
HCM_PENALIZED_STATES = frozenset({HCM_PENALTY, HCM_PENALTY_ANIMATION, HCM_PICKED_UP})
HCM_INACTIVE_STATES = frozenset({HCM_STARTUP, HCM_SHUTDOWN, HCM_RECORD})

# Strategy.msg numbering of roles, actions and sides (the codecs shift to their own numbering)
ROLE_GOALIE = 5
SIDE_LEFT, SIDE_MIDDLE, SIDE_RIGHT = 0, 1, 2
NOT_TOLD = 255  # in team_data: the teammate did not say (role, state, offensive side)


@dataclass(frozen=True, slots=True)
class SeenRobot:
    """A robot this robot sees, relative to itself (m); confidence 0..1."""

    x: float
    y: float
    confidence: float = 1.0


@dataclass(frozen=True, slots=True)
class TeammateReport:
    """One team message. Positions in metres and radians; None where the sender said nothing."""

    robot_id: int
    team_id: int = 0
    role: int | None = None  # Strategy.ROLE_*
    action: int | None = None  # Strategy.ACTION_*
    state: int | None = None  # RobotControlState
    offensive_side: int | None = None  # Strategy.SIDE_*
    position: tuple[float, float, float] | None = None  # absolute x, y, theta
    position_confidence: float = 0.0
    ball: tuple[float, float] | None = None  # relative to the robot
    ball_confidence: float = 0.0
    oppgoal: tuple[float, float] | None = None  # relative to the robot
    oppgoal_confidence: float = 0.0
    opponents: tuple[SeenRobot, ...] = field(default_factory=tuple)
    teammates: tuple[SeenRobot, ...] = field(default_factory=tuple)
    walking_speed: float | None = None  # m/s
    walk_command: tuple[float, float, float] | None = None  # m/s, m/s, rad/s (protobuf only)
    time_to_ball: float | None = None  # s
    max_kicking_distance: float | None = None  # m
    team_color: int | None = None  # GameState.BLUE / RED (protobuf only)
