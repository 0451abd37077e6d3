"""Humanoid League GameController wire format: the v12 state packet (RGme) and the v2 return packet (RGrt).

Pure codec, no sockets. Layout and constants: /work/shared/specs/gamecontroller.md (little endian, no padding).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from enum import IntEnum

STATE_HEADER = b"RGme"
RETURN_HEADER = b"RGrt"
STATE_VERSION = 12
RETURN_VERSION = 2
DATA_PORT = 3838
RETURN_PORT = 3939
MAX_NUM_PLAYERS = 11
COACH_MESSAGE_SIZE = 253

_TOP = struct.Struct("<4sHBBBBBBB4sBHhh")  # 24 bytes
_TEAM_HEAD = struct.Struct("<BBBBHB")  # 7 bytes, then the coach message
_ROBOT6 = struct.Struct("<BBBBBB")
_ROBOT4 = struct.Struct("<BBBB")  # the 2018 form: penalty, secs, yellow, red
_RETURN = struct.Struct("<4sBBBB")

TEAM_SIZE = _TEAM_HEAD.size + COACH_MESSAGE_SIZE + (1 + MAX_NUM_PLAYERS) * _ROBOT6.size  # 332
TEAM_SIZE_2018 = _TEAM_HEAD.size + COACH_MESSAGE_SIZE + (1 + MAX_NUM_PLAYERS) * _ROBOT4.size  # 308
PACKET_SIZE = _TOP.size + 2 * TEAM_SIZE  # 688
PACKET_SIZE_2018 = _TOP.size + 2 * TEAM_SIZE_2018  # 640
RETURN_SIZE = _RETURN.size  # 8

# Other packets that share the RGme magic, by (first version byte, length), to name them in errors.
_OTHER_PROTOCOLS: dict[tuple[int, int], str] = {
    (10, 588): "Humanoid League version 10 (2017)",
    (12, 54): "SPL version 12 (1-byte version field)",
    (13, 54): "SPL version 13",
    (14, 62): "SPL version 14",
    (15, 118): "SPL version 15",
    (16, 118): "SPL version 16",
    (17, 118): "SPL version 17",
    (18, 118): "SPL version 18",
    (19, 198): "Humanoid Soccer League version 19",
    (20, 158): "Humanoid Soccer League version 20",
}


class GameControllerPacketError(ValueError):
    """A datagram that is not a valid Humanoid League v12 GameController packet; the message says why."""


class GameStateValue(IntEnum):
    INITIAL = 0
    READY = 1
    SET = 2
    PLAYING = 3
    FINISHED = 4


class SecondaryState(IntEnum):
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


class Penalty(IntEnum):
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


class ReturnMessage(IntEnum):
    MAN_PENALISE = 0
    MAN_UNPENALISE = 1
    ALIVE = 2
    GOALKEEPER = 3
    GAME_INTERRUPTION_READY = 4


DROPBALL_TEAMS = frozenset({128, 255})  # Java GC writes 0x80, the C header and Rust GC 255


@dataclass(frozen=True, slots=True)
class RobotInfo:
    """One player slot of a team (players[0] is player number 1)."""

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
        return self.penalty == Penalty.SUBSTITUTE


def _substitute_slots() -> tuple[RobotInfo, ...]:
    return tuple(RobotInfo(penalty=Penalty.SUBSTITUTE) for _ in range(MAX_NUM_PLAYERS))


@dataclass(frozen=True, slots=True)
class TeamInfo:
    team_number: int = 0
    team_color: int = 0
    score: int = 0
    penalty_shot: int = 0
    single_shots: int = 0
    coach_sequence: int = 0
    coach_message: bytes = b""
    coach: RobotInfo = field(default_factory=RobotInfo)
    players: tuple[RobotInfo, ...] = field(default_factory=_substitute_slots)

    def player(self, number: int) -> RobotInfo | None:
        """Player by its number (1-based), None if out of the 11 slots."""
        return self.players[number - 1] if 1 <= number <= len(self.players) else None

    def active_players(self, players_per_team: int) -> dict[int, RobotInfo]:
        """Player number -> slot for robots that may be on the field: substitutes and unused slots are not."""
        return {
            i + 1: p for i, p in enumerate(self.players[:players_per_team]) if p.penalty != Penalty.SUBSTITUTE
        }

    @property
    def coach_text(self) -> str:
        return self.coach_message.split(b"\0", 1)[0].decode("utf-8", errors="replace")


@dataclass(frozen=True, slots=True)
class GameControlData:
    """One Humanoid League v12 state packet."""

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
    version: int = STATE_VERSION

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
    version: int = RETURN_VERSION


# -- state packet -----------------------------------------------------------------------------------------

def _check_range(name: str, value: int, lo: int, hi: int) -> None:
    if not lo <= value <= hi:
        raise GameControllerPacketError(f"impossible {name} {value} (expected {lo}..{hi})")


def _version_error(data: bytes) -> GameControllerPacketError:
    raw = int.from_bytes(data[4:6], "little")
    other = _OTHER_PROTOCOLS.get((data[4], len(data)))
    if other is not None:
        return GameControllerPacketError(
            f"GameController packet version {data[4]} ({other}, {len(data)} bytes) is not supported; "
            f"this receiver reads Humanoid League version {STATE_VERSION}"
        )
    return GameControllerPacketError(
        f"GameController packet version {raw} is not supported; this receiver reads Humanoid League "
        f"version {STATE_VERSION}"
    )


def parse_state_packet(data: bytes | bytearray | memoryview) -> GameControlData:
    """Decodes one datagram; GameControllerPacketError (and nothing else) for anything that is not HL v12."""
    data = bytes(data)
    if len(data) < 6:
        raise GameControllerPacketError(f"GameController packet too short: {len(data)} bytes")
    if data[:4] != STATE_HEADER:
        raise GameControllerPacketError(f"wrong GameController header {data[:4]!r}, expected {STATE_HEADER!r}")
    if int.from_bytes(data[4:6], "little") != STATE_VERSION:
        raise _version_error(data)
    if len(data) == PACKET_SIZE:
        robot, team_size = _ROBOT6, TEAM_SIZE
    elif len(data) == PACKET_SIZE_2018:
        robot, team_size = _ROBOT4, TEAM_SIZE_2018
    else:
        raise GameControllerPacketError(
            f"wrong size for a version {STATE_VERSION} GameController packet: {len(data)} bytes, "
            f"expected {PACKET_SIZE} (or {PACKET_SIZE_2018} for the 2018 form)"
        )
    (_, version, packet_number, players_per_team, game_type, state, first_half, kick_off_team, secondary_state,
     info, drop_in_team, drop_in_time, secs_remaining, secondary_time) = _TOP.unpack_from(data, 0)
    _check_range("players per team", players_per_team, 0, MAX_NUM_PLAYERS)
    _check_range("game state", state, 0, max(GameStateValue))
    _check_range("first half flag", first_half, 0, 1)
    _check_range("secondary state", secondary_state, 0, max(SecondaryState))
    teams = tuple(_parse_team(data, _TOP.size + i * team_size, robot) for i in range(2))
    return GameControlData(
        version=version,
        packet_number=packet_number,
        players_per_team=players_per_team,
        game_type=game_type,
        state=state,
        first_half=bool(first_half),
        kick_off_team=kick_off_team,
        secondary_state=secondary_state,
        secondary_state_info=(info[0], info[1], info[2], info[3]),
        drop_in_team=drop_in_team,
        drop_in_time=drop_in_time,
        secs_remaining=secs_remaining,
        secondary_time=secondary_time,
        teams=(teams[0], teams[1]),
    )


def _parse_team(data: bytes, offset: int, robot: struct.Struct) -> TeamInfo:
    number, color, score, penalty_shot, single_shots, coach_sequence = _TEAM_HEAD.unpack_from(data, offset)
    _check_range("team colour", color, 0, 9)
    offset += _TEAM_HEAD.size
    coach_message = data[offset:offset + COACH_MESSAGE_SIZE]
    offset += COACH_MESSAGE_SIZE
    slots = [_parse_robot(data, offset + i * robot.size, robot) for i in range(1 + MAX_NUM_PLAYERS)]
    return TeamInfo(
        team_number=number,
        team_color=color,
        score=score,
        penalty_shot=penalty_shot,
        single_shots=single_shots,
        coach_sequence=coach_sequence,
        coach_message=coach_message.rstrip(b"\0"),
        coach=slots[0],
        players=tuple(slots[1:]),
    )


def _parse_robot(data: bytes, offset: int, robot: struct.Struct) -> RobotInfo:
    if robot is _ROBOT4:
        penalty, secs, yellow, red = robot.unpack_from(data, offset)
        return RobotInfo(penalty, secs, 0, yellow, red, False)
    penalty, secs, warnings, yellow, red, goalkeeper = robot.unpack_from(data, offset)
    return RobotInfo(penalty, secs, warnings, yellow, red, bool(goalkeeper))


def build_state_packet(data: GameControlData) -> bytes:
    """The 688-byte v12 datagram a GameController sends (used by the simulated GC)."""
    try:
        out = bytearray(_TOP.pack(
            STATE_HEADER, STATE_VERSION, data.packet_number & 0xFF, data.players_per_team, data.game_type,
            int(data.state), int(data.first_half), data.kick_off_team, int(data.secondary_state),
            bytes(data.secondary_state_info), data.drop_in_team, data.drop_in_time, data.secs_remaining,
            data.secondary_time,
        ))
        for team in data.teams:
            if len(team.coach_message) > COACH_MESSAGE_SIZE:
                raise GameControllerPacketError(f"coach message longer than {COACH_MESSAGE_SIZE} bytes")
            if len(team.players) > MAX_NUM_PLAYERS:
                raise GameControllerPacketError(f"more than {MAX_NUM_PLAYERS} player slots")
            out += _TEAM_HEAD.pack(team.team_number, team.team_color, team.score, team.penalty_shot,
                                   team.single_shots, team.coach_sequence)
            out += team.coach_message.ljust(COACH_MESSAGE_SIZE, b"\0")
            players = list(team.players) + [RobotInfo(penalty=Penalty.SUBSTITUTE)] * (MAX_NUM_PLAYERS
                                                                                     - len(team.players))
            for p in [team.coach, *players]:
                out += _ROBOT6.pack(p.penalty, p.secs_till_unpenalized, p.warnings, p.yellow_cards, p.red_cards,
                                    int(p.goalkeeper))
    except (struct.error, ValueError, TypeError) as exc:
        if isinstance(exc, GameControllerPacketError):
            raise
        raise GameControllerPacketError(f"cannot encode GameController packet: {exc}") from exc
    return bytes(out)


# -- return packet ----------------------------------------------------------------------------------------

def build_return_packet(team: int, player: int, message: int = ReturnMessage.ALIVE) -> bytes:
    """The 8-byte RGrt v2 datagram: team before player (unlike the SPL return packet)."""
    _check_range("team number", team, 0, 255)
    _check_range("player number", player, 1, 255)
    _check_range("return message", int(message), 0, 255)
    return _RETURN.pack(RETURN_HEADER, RETURN_VERSION, team, player, int(message))


def parse_return_packet(data: bytes | bytearray | memoryview) -> ReturnPacket:
    """What a GameController receives on port 3939; GameControllerPacketError if it is not an HL v2 return."""
    data = bytes(data)
    if len(data) < 5 or data[:4] != RETURN_HEADER:
        raise GameControllerPacketError(f"wrong return packet header {data[:4]!r}, expected {RETURN_HEADER!r}")
    if data[4] != RETURN_VERSION:
        raise GameControllerPacketError(
            f"return packet version {data[4]} is not supported; expected {RETURN_VERSION}"
        )
    if len(data) != RETURN_SIZE:
        raise GameControllerPacketError(f"return packet must be {RETURN_SIZE} bytes, got {len(data)}")
    _, version, team, player, message = _RETURN.unpack(data)
    _check_range("player number", player, 1, 20)
    return ReturnPacket(team=team, player=player, message=message, version=version)
