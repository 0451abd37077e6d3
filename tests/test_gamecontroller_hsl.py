"""Humanoid Soccer League GameController v20 and v19 (2026) against packets built here from the spec's layout.

The structs below are written from /work/shared/specs/gamecontroller.md section 4.3 (not from pitchside's codec),
their sizes and offsets asserted, and the packets decoded by pitchside's codec and its GameState fields.
"""

from __future__ import annotations

import struct

import pytest

from robot_nodes.game_controller.receiver import gamestate_fields
from schemas.messages import GameState
from wire.gamecontroller.packets import (
    GameControllerPacketError,
    build_state_packet,
    packet_version,
    parse_state_packet,
)

# -- the spec's layout ----------------------------------------------------------------------------------------
TOP = struct.Struct("<4s B B B B B B B B B B h h")  # header .. secondaryTime
TEAM_HEAD = struct.Struct("<B B B B B B H H")  # teamNumber .. messageBudget
ROBOT_V20 = struct.Struct("<B B B")  # penalty, secsTillUnpenalised, cautions
ROBOT_V19 = struct.Struct("<B B B B")  # penalty, secsTillUnpenalised, warnings, cautions
PLAYERS = 20


def test_the_spec_layout_has_the_sizes_the_header_asserts() -> None:
    assert (TOP.size, TEAM_HEAD.size, ROBOT_V20.size, ROBOT_V19.size) == (18, 10, 3, 4)
    assert TEAM_HEAD.size + PLAYERS * ROBOT_V20.size == 70
    assert TOP.size + 2 * (TEAM_HEAD.size + PLAYERS * ROBOT_V20.size) == 158
    assert TOP.size + 2 * (TEAM_HEAD.size + PLAYERS * ROBOT_V19.size) == 198


def team_bytes(number: int, colour: int, keeper_colour: int, keeper: int, score: int, budget: int,
               robots: dict[int, tuple[int, ...]], robot: struct.Struct, shots: tuple[int, int] = (0, 0)) -> bytes:
    """robots: player number -> the RobotInfo fields of the version (others zero)."""
    out = TEAM_HEAD.pack(number, colour, keeper_colour, keeper, score, shots[0], shots[1], budget)
    for n in range(1, PLAYERS + 1):
        out += robot.pack(*robots.get(n, (0,) * robot.size))  # one byte per field
    return out


def spec_packet(version: int = 20, *, number: int = 7, players: int = 7, competition: int = 0, stopped: int = 0,
                phase: int = 0, state: int = 3, set_play: int = 0, first_half: int = 1, kicking: int = 13,
                secs: int = 421, secondary: int = 0, own: dict[int, tuple[int, ...]] | None = None,
                own_budget: int = 11_874, rival_budget: int = 12_000) -> bytes:
    robot = ROBOT_V20 if version == 20 else ROBOT_V19
    top = TOP.pack(b"RGme", version, number, players, competition, stopped, phase, state, set_play, first_half,
                   kicking, secs, secondary)
    teams = (team_bytes(13, 0, 2, 1, 1, own_budget, own or {}, robot, shots=(2, 0b01))
             + team_bytes(7, 1, 3, 2, 0, rival_budget, {}, robot))
    return top + teams


def test_offsets_of_the_v20_packet() -> None:
    raw = spec_packet(own={3: (6, 25, 1)}, kicking=13, secs=421, secondary=-2)
    assert len(raw) == 158
    assert raw[:4] == b"RGme" and raw[4] == 20 and raw[5] == 7 and raw[6] == 7
    assert raw[13] == 13  # kickingTeam
    assert struct.unpack_from("<hh", raw, 14) == (421, -2)
    assert raw[18:24] == bytes([13, 0, 2, 1, 1, 2])  # teams[0] head
    assert struct.unpack_from("<HH", raw, 24) == (0b01, 11_874)  # singleShots, messageBudget
    assert raw[28 + 2 * 3:28 + 3 * 3] == bytes([6, 25, 1])  # player 3 at teams[0] + 10 + 2 * 3
    assert raw[88] == 7 and struct.unpack_from("<H", raw, 96)[0] == 12_000  # teams[1] at 18 + 70


def test_v20_decodes_to_every_gamestate_field() -> None:
    raw = spec_packet(own={1: (0, 0, 0), 3: (6, 25, 1), 4: (13, 0, 0), 5: (12, 0, 2)}, competition=0, stopped=1,
                      phase=2, set_play=4, first_half=0, kicking=7, secs=421, secondary=27)
    p = parse_state_packet(raw)
    assert (p.version, p.packet_number, p.players_per_team, p.competition_type) == (20, 7, 7, 0)
    assert (p.stopped, p.game_phase, p.state, p.set_play, p.first_half, p.kicking_team) == (True, 2, 3, 4, False, 7)
    own = p.team(13)
    assert own is not None and (own.goalkeeper_color, own.goalkeeper, own.message_budget) == (2, 1, 11_874)
    assert build_state_packet(p) == raw, "re-encoding gives the bytes back"
    f = gamestate_fields(p, team_number=13, player_number=3)
    assert f is not None
    assert (f["version"], f["team_number"], f["competition_type"], f["players_per_team"]) == (20, 13, 0, 7)
    assert (f["game_state"], f["stopped"], f["game_phase"], f["set_play"], f["kicking_team"]) == (3, True, 2, 4, 7)
    assert (f["seconds_remaining"], f["secondary_seconds_remaining"], f["first_half"]) == (421, 27, False)
    assert (f["own_score"], f["rival_score"], f["penalty_shot"], f["single_shots"]) == (1, 0, 2, 1)
    assert (f["team_color"], f["goalkeeper_color"], f["rival_team_color"], f["rival_goalkeeper_color"]) == (0, 2, 1, 3)
    assert (f["goalkeeper"], f["message_budget"], f["rival_message_budget"]) == (1, 11_874, 12_000)
    assert (f["penalty"], f["penalized"], f["seconds_till_unpenalized"], f["cautions"]) == (6, True, 25, 1)
    assert not f["allowed_to_move"] and not f["penalized_in_place"] and not f["has_kick_off"]
    assert f["player_penalties"][:6] == [0, 0, 6, 13, 12, 0] and len(f["player_penalties"]) == 20
    assert f["player_cautions"][:5] == [0, 0, 1, 0, 2] and f["player_seconds_till_unpenalized"][2] == 25
    # the HL view: a throw-in for team 7 while the ball is placed (robots freeze)
    assert (f["secondary_state"], f["secondary_state_team"], f["secondary_state_mode"]) == (9, 7, 0)
    assert f["team_mates_with_penalty"] == [5] and f["team_mates_with_red_card"] == [5]  # 4 is a substitute


def test_v19_with_four_byte_robot_info_and_warnings() -> None:
    raw = spec_packet(19, own={2: (9, 30, 2, 1), 3: (11, 0, 0, 0)}, kicking=255)
    assert len(raw) == 198 and packet_version(raw) == 19
    p = parse_state_packet(raw)
    assert p.version == 19 and p.kicking_team == 255
    f = gamestate_fields(p, 13, 2)
    assert f is not None
    assert (f["penalty"], f["warnings"], f["cautions"]) == (GameState.PENALTY_PUSHING, 2, 1)  # v19 9 -> v20 10
    assert f["player_penalties"][:3] == [0, 10, 13]  # v19 substitute 11 -> 13
    assert f["team_mates_with_penalty"] == [] and f["player_warnings"][1] == 2
    assert build_state_packet(p) == raw


V20_PENALTIES = {0: "NONE", 1: "ILLEGAL_POSITIONING", 2: "MOTION_IN_SET", 3: "MOTION_IN_STOP", 4: "LOCAL_GAME_STUCK",
                 5: "INCAPABLE_ROBOT", 6: "PICK_UP", 7: "BALL_HOLDING", 8: "LEAVING_THE_FIELD",
                 9: "PLAYING_WITH_ARMS_HANDS", 10: "PUSHING", 11: "CAUTIONED", 12: "SENT_OFF", 13: "SUBSTITUTE"}
V19_PENALTIES = {0: "NONE", 1: "ILLEGAL_POSITIONING", 2: "MOTION_IN_SET", 3: "LOCAL_GAME_STUCK", 4: "INCAPABLE_ROBOT",
                 5: "PICK_UP", 6: "BALL_HOLDING", 7: "LEAVING_THE_FIELD", 8: "PLAYING_WITH_ARMS_HANDS", 9: "PUSHING",
                 10: "SENT_OFF", 11: "SUBSTITUTE"}


@pytest.mark.parametrize(("version", "code", "name"), [(20, c, n) for c, n in V20_PENALTIES.items()]
                         + [(19, c, n) for c, n in V19_PENALTIES.items()])
def test_every_penalty_code(version: int, code: int, name: str) -> None:
    robot = (code, 17, 0) if version == 20 else (code, 17, 0, 0)
    f = gamestate_fields(parse_state_packet(spec_packet(version, own={2: robot})), 13, 2)
    assert f is not None
    assert f["penalty"] == getattr(GameState, f"PENALTY_{name}")
    assert f["penalized"] == (code != 0)
    assert f["penalized_in_place"] == (name in ("MOTION_IN_SET", "MOTION_IN_STOP"))
    assert f["allowed_to_move"] == (code == 0)
    assert f["seconds_till_unpenalized"] == 17


SET_PLAYS = {0: ("SET_PLAY_NONE", 0), 1: ("SET_PLAY_DIRECT_FREE_KICK", 4), 2: ("SET_PLAY_INDIRECT_FREE_KICK", 5),
             3: ("SET_PLAY_PENALTY_KICK", 6), 4: ("SET_PLAY_THROW_IN", 9), 5: ("SET_PLAY_GOAL_KICK", 8),
             6: ("SET_PLAY_CORNER_KICK", 7)}


@pytest.mark.parametrize("set_play", sorted(SET_PLAYS))
@pytest.mark.parametrize("stopped", [0, 1])
def test_every_set_play_stopped_or_not(set_play: int, stopped: int) -> None:
    name, secondary = SET_PLAYS[set_play]
    f = gamestate_fields(parse_state_packet(spec_packet(set_play=set_play, stopped=stopped, kicking=13)), 13, 2)
    assert f is not None
    assert f["set_play"] == getattr(GameState, name) == set_play
    assert f["secondary_state"] == secondary
    assert f["stopped"] == bool(stopped) and f["has_kick_off"]
    assert f["allowed_to_move"] == (not stopped), "robots freeze while play is stopped"
    if set_play:
        assert (f["secondary_state_team"], f["secondary_state_mode"]) == (13, 0 if stopped else 1)


@pytest.mark.parametrize(("phase", "name"), [(0, "NORMAL"), (1, "PENALTY_SHOOT_OUT"), (2, "EXTRA_TIME"),
                                             (3, "TIMEOUT")])
def test_every_game_phase(phase: int, name: str) -> None:
    f = gamestate_fields(parse_state_packet(spec_packet(phase=phase)), 13, 2)
    assert f is not None
    assert f["game_phase"] == getattr(GameState, f"GAME_PHASE_{name}")
    assert f["secondary_state"] == phase  # HL's secondary states 0-3 are the same phases
    assert f["allowed_to_move"] == (phase != 3), "nobody moves in a timeout"


@pytest.mark.parametrize("competition", [0, 1, 2])
def test_every_competition_type(competition: int) -> None:
    f = gamestate_fields(parse_state_packet(spec_packet(competition=competition, players=5)), 13, 2)
    assert f is not None and f["competition_type"] == competition and f["players_per_team"] == 5


@pytest.mark.parametrize(("raw", "kind", "words"), [
    (spec_packet()[:157], "truncated", "157 bytes, expected 158"),
    (spec_packet()[:20], "truncated", "20 bytes, expected 158"),
    (spec_packet() + b"\0", "over_long", "159 bytes, expected 158"),
    (spec_packet(19)[:197], "truncated", "version 19"),
    (b"RGme\x15" + spec_packet()[5:], "wrong_version", "version"),
    (b"RGme\x12" + bytes(113), "wrong_version", "SPL version 18"),
    (b"RGTD" + spec_packet()[4:], "wrong_header", "header"),
    (b"RG", "truncated", "too short"),
])
def test_bad_input_is_named(raw: bytes, kind: str, words: str) -> None:
    with pytest.raises(GameControllerPacketError, match=words) as info:
        parse_state_packet(raw)
    assert info.value.kind == kind


@pytest.mark.parametrize(("offset", "value", "what"), [
    (10, 5, "game state"), (8, 2, "stopped"), (9, 4, "game phase"), (11, 7, "set play"), (12, 2, "first half"),
    (6, 21, "players per team"), (21, 21, "goalkeeper"),
])
def test_impossible_values_are_refused(offset: int, value: int, what: str) -> None:
    raw = bytearray(spec_packet())
    raw[offset] = value
    with pytest.raises(GameControllerPacketError, match=what) as info:
        parse_state_packet(bytes(raw))
    assert info.value.kind == "bad_value"


def test_hl_v12_gets_the_hsl_view_derived() -> None:
    from wire.gamecontroller.packets import GameControlData, RobotInfo, TeamInfo
    data = GameControlData(state=3, kick_off_team=5, secondary_state=8, secondary_state_info=(6, 1, 0, 0),
                           teams=(TeamInfo(5, 0, players=(RobotInfo(goalkeeper=True), RobotInfo(penalty=34))),
                                  TeamInfo(6, 1)))
    f = gamestate_fields(parse_state_packet(build_state_packet(data)), 5, 2)
    assert f is not None
    assert (f["version"], f["set_play"], f["kicking_team"], f["stopped"]) == (12, 5, 6, False)
    assert (f["goalkeeper"], f["penalty"], f["message_budget"]) == (1, GameState.PENALTY_PICK_UP, 65535)
    assert (f["competition_type"], f["goalkeeper_color"]) == (255, 255)
