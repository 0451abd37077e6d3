"""GameController wire format: which codec reads a datagram (by version byte and length), the Humanoid League v12
state packet (RGme, 688 bytes, and its 640-byte 2018 form) and the HL v2 return packet (RGrt); the Humanoid Soccer
League v19/v20 packets and the v4 status packet are in ``hsl``.

Pure codec, no sockets. Layout and constants: /work/shared/specs/gamecontroller.md (little endian, no padding).
"""

from __future__ import annotations

import struct

from wire.gamecontroller import hsl
from wire.gamecontroller.game_data import (
    DROPBALL_TEAMS,
    HL_VERSION,
    HSL_VERSION,
    HSL_VERSION_19,
    MAX_NUM_PLAYERS,
    SET_PIECES,
    GameControlData,
    GameControllerPacketError,
    GamePhase,
    GameStateValue,
    HslPenalty,
    HslPenaltyV19,
    Penalty,
    ReturnMessage,
    ReturnPacket,
    RobotInfo,
    SecondaryState,
    SetPlay,
    StatusPacket,
    TeamInfo,
)

STATE_HEADER = b"RGme"
RETURN_HEADER = b"RGrt"
STATE_VERSION = HL_VERSION
RETURN_VERSION = 2
DATA_PORT = 3838
RETURN_PORT = 3939
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
}
HSL_NAMES = {HSL_VERSION_19: "Humanoid Soccer League version 19", HSL_VERSION: "Humanoid Soccer League version 20"}
READS = "Humanoid Soccer League versions 20 and 19 and Humanoid League version 12"


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
            f"this receiver reads {READS}", "wrong_version")
    return GameControllerPacketError(
        f"GameController packet version {raw} (first byte {data[4]}, {len(data)} bytes) is not supported; "
        f"this receiver reads {READS}", "wrong_version")


def _size_error(version: int, length: int, expected: int, also: str = "") -> GameControllerPacketError:
    return GameControllerPacketError(
        f"wrong size for a version {version} GameController packet: {length} bytes, expected {expected}{also}",
        "truncated" if length < expected else "over_long")


def packet_version(data: bytes | bytearray | memoryview) -> int | None:
    """The version a datagram claims (12, 19, 20), None if it claims none pitchside reads."""
    if len(data) < 6 or bytes(data[:4]) != STATE_HEADER:
        return None
    if data[4] in HSL_NAMES:
        return int(data[4])
    return HL_VERSION if int.from_bytes(bytes(data[4:6]), "little") == HL_VERSION else None


def parse_state_packet(data: bytes | bytearray | memoryview) -> GameControlData:
    """Decodes one datagram of HSL v20 or v19 or HL v12 (chosen by version byte and length);
    GameControllerPacketError (and nothing else) for anything else."""
    data = bytes(data)
    if len(data) < 6:
        raise GameControllerPacketError(f"GameController packet too short: {len(data)} bytes", "truncated")
    if data[:4] != STATE_HEADER:
        raise GameControllerPacketError(f"wrong GameController header {data[:4]!r}, expected {STATE_HEADER!r}",
                                        "wrong_header")
    if data[4] in HSL_NAMES:
        expected = hsl.PACKET_SIZE[data[4]]
        if len(data) != expected:
            raise _size_error(data[4], len(data), expected, f" ({HSL_NAMES[data[4]]})")
        return hsl.parse_hsl_state_packet(data)
    if int.from_bytes(data[4:6], "little") != STATE_VERSION:
        raise _version_error(data)
    if len(data) == PACKET_SIZE:
        robot, team_size = _ROBOT6, TEAM_SIZE
    elif len(data) == PACKET_SIZE_2018:
        robot, team_size = _ROBOT4, TEAM_SIZE_2018
    else:
        if (data[4], len(data)) in _OTHER_PROTOCOLS:  # SPL v12 with packet number 0 looks like HL v12
            raise _version_error(data)
        raise _size_error(STATE_VERSION, len(data), PACKET_SIZE if len(data) > PACKET_SIZE_2018 else PACKET_SIZE_2018,
                          f" (or {PACKET_SIZE_2018} for the 2018 form)" if len(data) > PACKET_SIZE_2018
                          else f" (or {PACKET_SIZE})")
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
    """The datagram a GameController sends, in ``data.version``: 688-byte HL v12, 158-byte v20 or 198-byte v19
    (used by the simulated GC and tests)."""
    if data.version in HSL_NAMES:
        return hsl.build_hsl_state_packet(data)
    if data.version != STATE_VERSION:
        raise GameControllerPacketError(f"cannot encode version {data.version}; one of 12, 19, 20",
                                        "wrong_version")
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
        raise GameControllerPacketError(f"wrong return packet header {data[:4]!r}, expected {RETURN_HEADER!r}",
                                        "wrong_header")
    if data[4] != RETURN_VERSION:
        raise GameControllerPacketError(
            f"return packet version {data[4]} is not supported; expected {RETURN_VERSION}"
        )
    if len(data) != RETURN_SIZE:
        raise GameControllerPacketError(f"return packet must be {RETURN_SIZE} bytes, got {len(data)}")
    _, version, team, player, message = _RETURN.unpack(data)
    _check_range("player number", player, 1, 20)
    return ReturnPacket(team=team, player=player, message=message, version=version)


def parse_any_return_packet(data: bytes | bytearray | memoryview) -> ReturnPacket | StatusPacket:
    """What arrives on port 3939: an HL v2 return packet or an HSL v4 status packet, by its version byte."""
    data = bytes(data)
    if len(data) >= 5 and data[:4] == RETURN_HEADER and data[4] == hsl.STATUS_VERSION:
        return hsl.parse_status_packet(data)
    return parse_return_packet(data)


build_status_packet = hsl.build_status_packet
parse_status_packet = hsl.parse_status_packet
hl_to_hsl = hsl.hl_to_hsl
HSL_PACKET_SIZE = hsl.PACKET_SIZE
STATUS_SIZE = hsl.STATUS_SIZE

__all__ = [
    "DATA_PORT", "DROPBALL_TEAMS", "HL_VERSION", "HSL_NAMES", "HSL_PACKET_SIZE", "HSL_VERSION", "HSL_VERSION_19",
    "MAX_NUM_PLAYERS", "PACKET_SIZE", "PACKET_SIZE_2018", "RETURN_PORT", "RETURN_SIZE", "SET_PIECES", "STATUS_SIZE",
    "GameControlData", "GameControllerPacketError", "GamePhase", "GameStateValue", "HslPenalty", "HslPenaltyV19",
    "Penalty", "ReturnMessage", "ReturnPacket", "RobotInfo", "SecondaryState", "SetPlay", "StatusPacket", "TeamInfo",
    "build_return_packet", "build_state_packet", "build_status_packet", "hl_to_hsl", "packet_version",
    "parse_any_return_packet", "parse_return_packet", "parse_state_packet", "parse_status_packet",
]
