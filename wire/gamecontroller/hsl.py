"""Humanoid Soccer League GameController wire format (2026): the RGme v19 and v20 state packets and the RGrt v4
status packet robots answer with.

Pure codec, no sockets. Little endian, no padding. v20 (158 bytes): an 18-byte top, two 70-byte teams of a
10-byte head and 20 three-byte RobotInfo (penalty, secsTillUnpenalised, cautions); v19 (198 bytes) has four-byte
RobotInfo (penalty, secsTillUnpenalised, warnings, cautions). Spec: /work/shared/specs/gamecontroller.md 4.2, 4.3.
"""

from __future__ import annotations

import math
import struct

from wire.gamecontroller.game_data import (
    HSL_MAX_NUM_PLAYERS,
    HSL_VERSION,
    HSL_VERSION_19,
    PENALTY_FROM_HL,
    SUBSTITUTE_PENALTY,
    GameControlData,
    GameControllerPacketError,
    GamePhase,
    GameStateValue,
    RobotInfo,
    SetPlay,
    StatusPacket,
    TeamInfo,
)

STATE_HEADER = b"RGme"
STATUS_HEADER = b"RGrt"
STATUS_VERSION = 4

_TOP = struct.Struct("<4sBBBBBBBBBBhh")  # 18 bytes
_TEAM_HEAD = struct.Struct("<BBBBBBHH")  # 10 bytes: number, colours, goalkeeper, score, shots, budget
_ROBOT = {HSL_VERSION: struct.Struct("<BBB"), HSL_VERSION_19: struct.Struct("<BBBB")}
_STATUS = struct.Struct("<4sBBBB3ff2f")  # 32 bytes

TEAM_SIZE = {v: _TEAM_HEAD.size + HSL_MAX_NUM_PLAYERS * r.size for v, r in _ROBOT.items()}  # 70 / 90
PACKET_SIZE = {v: _TOP.size + 2 * size for v, size in TEAM_SIZE.items()}  # 158 / 198
STATUS_SIZE = _STATUS.size  # 32


def _check_range(name: str, value: int, lo: int, hi: int) -> None:
    if not lo <= value <= hi:
        raise GameControllerPacketError(f"impossible {name} {value} (expected {lo}..{hi})")


def parse_hsl_state_packet(data: bytes) -> GameControlData:
    """A v19 or v20 packet whose magic, version and length the caller has checked."""
    version = data[4]
    robot = _ROBOT[version]
    (_, _, packet_number, players_per_team, competition_type, stopped, game_phase, state, set_play, first_half,
     kicking_team, secs_remaining, secondary_time) = _TOP.unpack_from(data, 0)
    _check_range("players per team", players_per_team, 0, HSL_MAX_NUM_PLAYERS)
    _check_range("stopped flag", stopped, 0, 1)
    _check_range("game phase", game_phase, 0, max(GamePhase))
    _check_range("game state", state, 0, max(GameStateValue))
    _check_range("set play", set_play, 0, max(SetPlay))
    _check_range("first half flag", first_half, 0, 1)
    teams = [_parse_team(data, _TOP.size + i * TEAM_SIZE[version], robot) for i in range(2)]
    return GameControlData(
        version=version, packet_number=packet_number, players_per_team=players_per_team,
        competition_type=competition_type, stopped=bool(stopped), game_phase=game_phase, state=state,
        set_play=set_play, first_half=bool(first_half), kicking_team=kicking_team, secs_remaining=secs_remaining,
        secondary_time=secondary_time, teams=(teams[0], teams[1]),
    )


def _parse_team(data: bytes, offset: int, robot: struct.Struct) -> TeamInfo:
    (number, color, goalkeeper_color, goalkeeper, score, penalty_shot, single_shots,
     budget) = _TEAM_HEAD.unpack_from(data, offset)
    _check_range("goalkeeper number", goalkeeper, 0, HSL_MAX_NUM_PLAYERS)
    offset += _TEAM_HEAD.size
    players = []
    for i in range(HSL_MAX_NUM_PLAYERS):
        fields = robot.unpack_from(data, offset + i * robot.size)
        penalty, secs = fields[0], fields[1]
        warnings, cautions = (0, fields[2]) if robot.size == 3 else (fields[2], fields[3])
        players.append(RobotInfo(penalty=penalty, secs_till_unpenalized=secs, warnings=warnings,
                                 yellow_cards=cautions, goalkeeper=i + 1 == goalkeeper))
    return TeamInfo(team_number=number, team_color=color, goalkeeper_color=goalkeeper_color, goalkeeper=goalkeeper,
                    score=score, penalty_shot=penalty_shot, single_shots=single_shots, message_budget=budget,
                    players=tuple(players))


def build_hsl_state_packet(data: GameControlData) -> bytes:
    """The v19 or v20 datagram for ``data`` (its ``version``); player slots beyond those given are substitutes."""
    version = data.version
    robot = _ROBOT[version]
    substitute = SUBSTITUTE_PENALTY[version]
    try:
        out = bytearray(_TOP.pack(
            STATE_HEADER, version, data.packet_number & 0xFF, data.players_per_team, int(data.competition_type),
            int(data.stopped), int(data.game_phase), int(data.state), int(data.set_play), int(data.first_half),
            data.kicking_team, data.secs_remaining, data.secondary_time,
        ))
        for team in data.teams:
            if len(team.players) > HSL_MAX_NUM_PLAYERS:
                raise GameControllerPacketError(f"more than {HSL_MAX_NUM_PLAYERS} player slots")
            color = team.goalkeeper_color
            out += _TEAM_HEAD.pack(team.team_number, team.team_color, color, team.goalkeeper_number, team.score,
                                   team.penalty_shot, team.single_shots, team.message_budget)
            players = list(team.players) + [RobotInfo(penalty=substitute)] * (HSL_MAX_NUM_PLAYERS
                                                                            - len(team.players))
            for p in players:
                if robot.size == 3:
                    out += robot.pack(p.penalty, p.secs_till_unpenalized, p.cautions)
                else:
                    out += robot.pack(p.penalty, p.secs_till_unpenalized, p.warnings, p.cautions)
    except (struct.error, ValueError, TypeError) as exc:
        if isinstance(exc, GameControllerPacketError):
            raise
        raise GameControllerPacketError(f"cannot encode a version {version} GameController packet: {exc}") from exc
    return bytes(out)


def hl_to_hsl(data: GameControlData, version: int = HSL_VERSION) -> GameControlData:
    """An HL v12 game told as an HSL packet of ``version``: set plays and phases from the secondary state, HL
    penalty codes in the version's numbering, slots filled up to 20 (a simulated GameController keeps HL codes)."""
    codes = PENALTY_FROM_HL[version]
    substitute = SUBSTITUTE_PENALTY[version]

    def team(t: TeamInfo) -> TeamInfo:
        players = tuple(RobotInfo(penalty=codes.get(p.penalty, p.penalty),
                                  secs_till_unpenalized=p.secs_till_unpenalized, warnings=p.warnings,
                                  yellow_cards=p.yellow_cards, red_cards=p.red_cards,
                                  goalkeeper=p.goalkeeper) for p in t.players)
        players += (RobotInfo(penalty=substitute),) * (HSL_MAX_NUM_PLAYERS - len(players))
        return TeamInfo(team_number=t.team_number, team_color=t.team_color,
                        goalkeeper_color=t.goalkeeper_color if t.goalkeeper_color != 255 else t.team_color,
                        goalkeeper=t.goalkeeper_number, score=t.score, penalty_shot=t.penalty_shot,
                        single_shots=t.single_shots, message_budget=t.message_budget, players=players)

    return GameControlData(
        version=version, packet_number=data.packet_number, players_per_team=data.players_per_team,
        competition_type=data.competition_type, stopped=data.stopped, game_phase=data.game_phase,
        state=data.state, set_play=data.set_play, first_half=data.first_half, kicking_team=data.kicking_team,
        secs_remaining=data.secs_remaining, secondary_time=data.secondary_time,
        teams=(team(data.teams[0]), team(data.teams[1])),
    )


# -- status (return) packet v4 ----------------------------------------------------------------------------

def _finite_or(value: float, default: float) -> float:
    return value if math.isfinite(value) else default


def build_status_packet(status: StatusPacket) -> bytes:
    """The 32-byte RGrt v4 datagram: player before team (unlike HL's v2); non-finite numbers are sent as
    unknown (pose 0, ball age -1)."""
    _check_range("player number", status.player, 1, 255)
    _check_range("team number", status.team, 0, 255)
    _check_range("fallen", status.fallen, 0, 255)
    x, y, theta = (_finite_or(v, 0.0) for v in status.pose_mm)
    bx, by = (_finite_or(v, 0.0) for v in status.ball_mm)
    age = _finite_or(status.ball_age_s, -1.0)
    try:
        return _STATUS.pack(STATUS_HEADER, STATUS_VERSION, status.player, status.team, status.fallen, x, y, theta,
                            age, bx, by)
    except (struct.error, OverflowError) as exc:
        raise GameControllerPacketError(f"cannot encode a status packet: {exc}") from exc


def parse_status_packet(data: bytes | bytearray | memoryview) -> StatusPacket:
    """What an HSL GameController receives on port 3939; GameControllerPacketError if it is not RGrt v4."""
    data = bytes(data)
    if len(data) < 5 or data[:4] != STATUS_HEADER:
        raise GameControllerPacketError(f"wrong status packet header {data[:4]!r}, expected {STATUS_HEADER!r}")
    if data[4] != STATUS_VERSION:
        raise GameControllerPacketError(f"status packet version {data[4]} is not supported; expected 4")
    if len(data) != STATUS_SIZE:
        raise GameControllerPacketError(f"status packet must be {STATUS_SIZE} bytes, got {len(data)}")
    _, _, player, team, fallen, x, y, theta, age, bx, by = _STATUS.unpack(data)
    _check_range("player number", player, 1, HSL_MAX_NUM_PLAYERS)
    return StatusPacket(team=team, player=player, fallen=fallen, pose_mm=(x, y, theta), ball_age_s=age,
                        ball_mm=(bx, by))
