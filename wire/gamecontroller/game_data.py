"""What a GameController packet says, whatever its version: the enums, codes and data classes the codecs fill.

One ``GameControlData`` carries both the Humanoid League v12 view (secondary state with its set-piece sub-phase)
and the Humanoid Soccer League v19/v20 view (game phase, set play, kicking team, ``stopped``). The fields native to
the packet's version are the ones given; the others are derived from them in ``__post_init__``, so code written
for either view reads any packet. Layouts and codes: /work/shared/specs/gamecontroller.md sections 2, 4 and 5.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

HL_VERSION = 12
HSL_VERSION_19 = 19
HSL_VERSION = 20
HSL_TEAM_PORT_BASE = 10_000  # team messages go by UDP broadcast to 10000 + team number
HSL_MAX_PAYLOAD = 512  # bytes of payload per team message
STATE_VERSIONS = (HL_VERSION, HSL_VERSION_19, HSL_VERSION)
MAX_NUM_PLAYERS = 11  # HL v12 player slots
HSL_MAX_NUM_PLAYERS = 20  # HSL v19/v20 player slots
NO_TEAM = 255  # HSL kickingTeam when nobody kicks
UNKNOWN = 255  # a colour or competition type a v12 packet does not tell


class GameControllerPacketError(ValueError):
    """A datagram that is not a valid GameController packet of a version pitchside reads; the message says why and
    ``kind`` names the fault for counting: truncated, over_long, wrong_header, wrong_version or bad_value."""

    def __init__(self, message: str, kind: str = "bad_value") -> None:
        super().__init__(message)
        self.kind = kind


class GameStateValue(IntEnum):
    INITIAL = 0
    READY = 1
    SET = 2
    PLAYING = 3
    FINISHED = 4


class SecondaryState(IntEnum):
    """HL v12 secondaryState."""

    NORMAL = 0
    PENALTYSHOOT = 1
    OVERTIME = 2
    TIMEOUT = 3
    DIRECT_FREEKICK = 4
    INDIRECT_FREEKICK = 5
    PENALTYKICK = 6
    CORNER_KICK = 7
    GOAL_KICK = 8
    THROW_IN = 9


SET_PIECES = frozenset(range(SecondaryState.DIRECT_FREEKICK, SecondaryState.THROW_IN + 1))


class GamePhase(IntEnum):
    """HSL gamePhase."""

    NORMAL = 0
    PENALTY_SHOOT_OUT = 1
    EXTRA_TIME = 2
    TIMEOUT = 3


class SetPlay(IntEnum):
    """HSL setPlay."""

    NONE = 0
    DIRECT_FREE_KICK = 1
    INDIRECT_FREE_KICK = 2
    PENALTY_KICK = 3
    THROW_IN = 4
    GOAL_KICK = 5
    CORNER_KICK = 6


class CompetitionType(IntEnum):
    """HSL competitionType (the size class)."""

    SMALL = 0
    MIDDLE = 1
    LARGE = 2


class Penalty(IntEnum):
    """HL v12 penalty codes."""

    NONE = 0
    SUBSTITUTE = 14
    MANUAL = 15
    BALL_MANIPULATION = 30
    PHYSICAL_CONTACT = 31
    ILLEGAL_ATTACK = 32
    ILLEGAL_DEFENSE = 33
    PICKUP_OR_INCAPABLE = 34
    SERVICE = 35
    UNKNOWN = 255


class HslPenalty(IntEnum):
    """HSL v20 penalty codes: the numbering pitchside's GameState uses for every version."""

    NONE = 0
    ILLEGAL_POSITIONING = 1
    MOTION_IN_SET = 2
    MOTION_IN_STOP = 3
    LOCAL_GAME_STUCK = 4
    INCAPABLE_ROBOT = 5
    PICK_UP = 6
    BALL_HOLDING = 7
    LEAVING_THE_FIELD = 8
    PLAYING_WITH_ARMS_HANDS = 9
    PUSHING = 10
    CAUTIONED = 11
    SENT_OFF = 12
    SUBSTITUTE = 13
    HL_MANUAL = 15  # HL v12's manual penalty (a robot's own request); the HSL GameController has none


class HslPenaltyV19(IntEnum):
    """HSL v19 penalty codes (March 2026): v20 inserted MOTION_IN_STOP and CAUTIONED."""

    NONE = 0
    ILLEGAL_POSITIONING = 1
    MOTION_IN_SET = 2
    LOCAL_GAME_STUCK = 3
    INCAPABLE_ROBOT = 4
    PICK_UP = 5
    BALL_HOLDING = 6
    LEAVING_THE_FIELD = 7
    PLAYING_WITH_ARMS_HANDS = 8
    PUSHING = 9
    SENT_OFF = 10
    SUBSTITUTE = 11


# a penalty code of each version in the v20 numbering (what GameState says); unknown codes are kept as they are
PENALTY_TO_V20: dict[int, dict[int, int]] = {
    HSL_VERSION: {int(p): int(p) for p in HslPenalty},
    HSL_VERSION_19: {int(p): int(HslPenalty[p.name]) for p in HslPenaltyV19},
    HL_VERSION: {
        Penalty.NONE: HslPenalty.NONE,
        Penalty.SUBSTITUTE: HslPenalty.SUBSTITUTE,
        Penalty.MANUAL: HslPenalty.HL_MANUAL,
        Penalty.BALL_MANIPULATION: HslPenalty.PLAYING_WITH_ARMS_HANDS,
        Penalty.PHYSICAL_CONTACT: HslPenalty.PUSHING,
        Penalty.ILLEGAL_ATTACK: HslPenalty.ILLEGAL_POSITIONING,
        Penalty.ILLEGAL_DEFENSE: HslPenalty.ILLEGAL_POSITIONING,
        Penalty.PICKUP_OR_INCAPABLE: HslPenalty.PICK_UP,
        Penalty.SERVICE: HslPenalty.INCAPABLE_ROBOT,
    },
}
# the other way, for a simulated GameController that keeps HL codes and speaks v19/v20
PENALTY_FROM_HL: dict[int, dict[int, int]] = {
    HSL_VERSION: {
        Penalty.NONE: HslPenalty.NONE, Penalty.SUBSTITUTE: HslPenalty.SUBSTITUTE,
        Penalty.MANUAL: HslPenalty.PICK_UP, Penalty.BALL_MANIPULATION: HslPenalty.PLAYING_WITH_ARMS_HANDS,
        Penalty.PHYSICAL_CONTACT: HslPenalty.PUSHING, Penalty.ILLEGAL_ATTACK: HslPenalty.ILLEGAL_POSITIONING,
        Penalty.ILLEGAL_DEFENSE: HslPenalty.ILLEGAL_POSITIONING, Penalty.PICKUP_OR_INCAPABLE: HslPenalty.PICK_UP,
        Penalty.SERVICE: HslPenalty.INCAPABLE_ROBOT,
    },
}
PENALTY_FROM_HL[HSL_VERSION_19] = {
    hl: int(HslPenaltyV19[HslPenalty(v20).name]) for hl, v20 in PENALTY_FROM_HL[HSL_VERSION].items()
}
SUBSTITUTE_PENALTY = {HL_VERSION: int(Penalty.SUBSTITUTE), HSL_VERSION_19: int(HslPenaltyV19.SUBSTITUTE),
                      HSL_VERSION: int(HslPenalty.SUBSTITUTE)}
# penalties served standing on the field (the robot is not taken out)
IN_PLACE_PENALTIES = frozenset({HslPenalty.MOTION_IN_SET, HslPenalty.MOTION_IN_STOP})


def penalty_v20(version: int, code: int) -> int:
    """A penalty code of ``version`` in the v20 numbering GameState uses."""
    return PENALTY_TO_V20.get(version, {}).get(code, code)


class ReturnMessage(IntEnum):
    MAN_PENALISE = 0
    MAN_UNPENALISE = 1
    ALIVE = 2
    GOALKEEPER = 3
    GAME_INTERRUPTION_READY = 4


DROPBALL_TEAMS = frozenset({128, 255})  # Java GC writes 0x80, the C header and Rust GC 255

# the HL secondary state of each HSL set play and back
_SECONDARY_OF_SET_PLAY = {
    SetPlay.DIRECT_FREE_KICK: SecondaryState.DIRECT_FREEKICK,
    SetPlay.INDIRECT_FREE_KICK: SecondaryState.INDIRECT_FREEKICK,
    SetPlay.PENALTY_KICK: SecondaryState.PENALTYKICK,
    SetPlay.THROW_IN: SecondaryState.THROW_IN,
    SetPlay.GOAL_KICK: SecondaryState.GOAL_KICK,
    SetPlay.CORNER_KICK: SecondaryState.CORNER_KICK,
}
_SET_PLAY_OF_SECONDARY = {int(v): int(k) for k, v in _SECONDARY_OF_SET_PLAY.items()}
# HL set-piece sub-phases: 0 robots freeze while the ball is placed, 1 robots may position, 2 freeze again
_PLACE_BALL, _POSITIONING, _REMOVE_ILLEGAL = 0, 1, 2


@dataclass(frozen=True, slots=True)
class RobotInfo:
    """One player slot of a team (players[0] is player number 1). HSL cautions are kept as yellow cards."""

    penalty: int = 0
    secs_till_unpenalized: int = 0
    warnings: int = 0
    yellow_cards: int = 0
    red_cards: int = 0
    goalkeeper: bool = False

    @property
    def penalized(self) -> bool:
        return self.penalty != Penalty.NONE

    @property
    def substitute(self) -> bool:
        """HL v12's substitute code; for other versions ask ``GameControlData.is_substitute``."""
        return self.penalty == Penalty.SUBSTITUTE

    @property
    def cautions(self) -> int:
        return self.yellow_cards


def _substitute_slots() -> tuple[RobotInfo, ...]:
    return tuple(RobotInfo(penalty=Penalty.SUBSTITUTE) for _ in range(MAX_NUM_PLAYERS))


@dataclass(frozen=True, slots=True)
class TeamInfo:
    team_number: int = 0
    team_color: int = 0  # the field players' colour
    score: int = 0
    penalty_shot: int = 0
    single_shots: int = 0
    coach_sequence: int = 0
    coach_message: bytes = b""
    coach: RobotInfo = field(default_factory=RobotInfo)
    players: tuple[RobotInfo, ...] = field(default_factory=_substitute_slots)
    # HSL v19/v20 (v12: unknown colour, goalkeeper from the players' flags, no budget)
    goalkeeper_color: int = UNKNOWN
    goalkeeper: int = 0  # player number of the goalkeeper, 0 none
    message_budget: int = 0  # team messages the team may still send in this game

    def player(self, number: int) -> RobotInfo | None:
        """Player by its number (1-based), None if out of the packet's slots."""
        return self.players[number - 1] if 1 <= number <= len(self.players) else None

    def active_players(self, players_per_team: int,
                       substitute: int = Penalty.SUBSTITUTE) -> dict[int, RobotInfo]:
        """Player number -> slot for robots that may be on the field: substitutes and unused slots are not.
        ``substitute``: the version's substitute code (GameControlData.substitute_penalty)."""
        return {i + 1: p for i, p in enumerate(self.players[:players_per_team]) if p.penalty != substitute}

    @property
    def goalkeeper_number(self) -> int:
        """The goalkeeper's player number: HSL says it per team, HL v12 per player."""
        if self.goalkeeper:
            return self.goalkeeper
        return next((i + 1 for i, p in enumerate(self.players) if p.goalkeeper), 0)

    @property
    def coach_text(self) -> str:
        return self.coach_message.split(b"\0", 1)[0].decode("utf-8", errors="replace")


@dataclass(frozen=True, slots=True)
class GameControlData:
    """One GameController state packet of any version pitchside reads (see the module docstring)."""

    packet_number: int = 0
    players_per_team: int = 4
    game_type: int = 0
    state: int = GameStateValue.INITIAL
    first_half: bool = True
    kick_off_team: int = 0
    secondary_state: int = SecondaryState.NORMAL
    secondary_state_info: tuple[int, int, int, int] = (0, 0, 0, 0)
    drop_in_team: int = 0
    drop_in_time: int = 0xFFFF
    secs_remaining: int = 600
    secondary_time: int = 0
    teams: tuple[TeamInfo, TeamInfo] = (TeamInfo(), TeamInfo())
    version: int = HL_VERSION
    # HSL v19/v20 (derived from the HL fields for a v12 packet)
    competition_type: int = CompetitionType.SMALL
    stopped: bool = False
    game_phase: int = GamePhase.NORMAL
    set_play: int = SetPlay.NONE
    kicking_team: int = NO_TEAM

    def __post_init__(self) -> None:
        if self.version == HL_VERSION:
            self._derive_hsl_view()
        else:
            self._derive_hl_view()

    def _derive_hsl_view(self) -> None:
        sec, info = int(self.secondary_state), self.secondary_state_info
        set_play = _SET_PLAY_OF_SECONDARY.get(sec, SetPlay.NONE)
        dropball = self.kick_off_team in DROPBALL_TEAMS
        kicking = info[0] if set_play else NO_TEAM if dropball else self.kick_off_team
        _set = object.__setattr__
        _set(self, "game_phase", sec if sec in (1, 2, 3) else GamePhase.NORMAL)
        _set(self, "set_play", set_play)
        _set(self, "kicking_team", kicking)
        _set(self, "stopped", bool(set_play) and info[1] in (_PLACE_BALL, _REMOVE_ILLEGAL))

    def _derive_hl_view(self) -> None:
        set_play = int(self.set_play)
        _set = object.__setattr__
        if set_play in _SECONDARY_OF_SET_PLAY:
            _set(self, "secondary_state", int(_SECONDARY_OF_SET_PLAY[SetPlay(set_play)]))
            _set(self, "secondary_state_info",
                 (self.kicking_team, _PLACE_BALL if self.stopped else _POSITIONING, 0, 0))
        else:
            phase = int(self.game_phase)
            _set(self, "secondary_state", phase if phase in (1, 2, 3) else SecondaryState.NORMAL)
            _set(self, "secondary_state_info", (0, 0, 0, 0))
        _set(self, "kick_off_team", self.kicking_team)
        _set(self, "drop_in_team", 0)
        _set(self, "drop_in_time", 0xFFFF)

    @property
    def hsl(self) -> bool:
        return self.version != HL_VERSION

    @property
    def substitute_penalty(self) -> int:
        return SUBSTITUTE_PENALTY.get(self.version, Penalty.SUBSTITUTE)

    def is_substitute(self, slot: RobotInfo) -> bool:
        return slot.penalty == self.substitute_penalty

    def team(self, team_number: int) -> TeamInfo | None:
        """Our team by number: team order in the packet is not fixed (side mapping)."""
        for t in self.teams:
            if t.team_number == team_number:
                return t
        return None

    def rival(self, team_number: int) -> TeamInfo | None:
        if self.team(team_number) is None:
            return None
        return next((t for t in self.teams if t.team_number != team_number), self.teams[1])

    @property
    def dropball(self) -> bool:
        return self.kick_off_team in DROPBALL_TEAMS


@dataclass(frozen=True, slots=True)
class ReturnPacket:
    """HL return packet v2: a robot tells the GC it is alive (or asks for a manual (un)penalty)."""

    team: int
    player: int
    message: int = ReturnMessage.ALIVE
    version: int = 2


@dataclass(frozen=True, slots=True)
class StatusPacket:
    """HSL/SPL return packet v4 (a robot's status): fallen, pose in the field frame and the ball it sees.

    Pose: mm, origin at the centre, +x towards the goal the robot attacks, +y 90 degrees counter-clockwise, theta
    in rad. Ball: relative to the robot in mm, ``ball_age_s`` since it was last seen (-1: never)."""

    team: int
    player: int
    fallen: int = 255  # 1 fallen, 0 upright, 255 not known
    pose_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    ball_age_s: float = -1.0
    ball_mm: tuple[float, float] = (0.0, 0.0)
    version: int = 4
