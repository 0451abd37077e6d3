"""GameController codec against real captured packets (tests/data/gamecontroller) and the spec's bytes."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest

from robot_nodes.game_controller.receiver import gamestate_fields
from wire.gamecontroller.packets import (
    PACKET_SIZE,
    PACKET_SIZE_2018,
    GameControlData,
    GameControllerPacketError,
    Penalty,
    ReturnMessage,
    RobotInfo,
    TeamInfo,
    build_return_packet,
    build_state_packet,
    parse_return_packet,
    parse_state_packet,
)

# What EXPECTED.md says each capture must decode to (written out, so a failing row names itself).
# (state, secondary state, secondary info, secs remaining, secondary time, {team: score},
#  {(team, player): (penalty, secs)} for penalties other than substitute)
GAME_A = {"teams": (2, 3), "colors": {2: 1, 3: 0}}
GAME_B = {"teams": (1, 2), "colors": {1: 1, 2: 0}}
EXPECTED = {
    "hl_v12_initial.bin": (GAME_A, 0, 0, (0, 0, 0, 0), 600, 0, {2: 0, 3: 0}, {}),
    "hl_v12_ready.bin": (GAME_A, 1, 0, (0, 0, 0, 0), 600, 42, {2: 0, 3: 0}, {}),
    "hl_v12_set.bin": (GAME_A, 2, 0, (0, 0, 0, 0), 600, 0, {2: 0, 3: 0}, {}),
    "hl_v12_playing.bin": (GAME_A, 3, 0, (0, 0, 0, 0), 596, 6, {2: 0, 3: 0}, {}),
    "hl_v12_playing_red2_penalized.bin": (GAME_A, 3, 0, (0, 0, 0, 0), 576, 0, {2: 0, 3: 0}, {(2, 2): (34, 30)}),
    "hl_v12_direct_free_kick.bin": (GAME_B, 3, 4, (2, 0, 0, 0), 568, 0, {1: 1, 2: 0}, {(1, 1): (31, 30)}),
    "hl_v12_free_kick_manual_penalise.bin": (GAME_B, 3, 4, (2, 1, 0, 0), 568, 24, {1: 1, 2: 0},
                                             {(1, 1): (31, 30), (2, 2): (15, 0)}),
    "hl_v12_finished.bin": (GAME_B, 4, 0, (0, 0, 0, 0), 564, 300, {1: 1, 2: 0}, {(1, 1): (31, 30)}),
}


def _captures(testdata: Path) -> dict[str, bytes]:
    folder = testdata / "gamecontroller"
    return {p.name: p.read_bytes() for p in sorted(folder.glob("*.bin"))}


def test_every_capture_is_listed_in_expected_md(testdata: Path) -> None:
    text = (testdata / "gamecontroller" / "EXPECTED.md").read_text()
    names = set(_captures(testdata))
    assert names == set(EXPECTED)
    for name in names:
        assert f"| {name} |" in text, f"{name} has no row in EXPECTED.md"


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_capture_decodes_as_the_gamecontroller_showed(testdata: Path, name: str) -> None:
    data = (testdata / "gamecontroller" / name).read_bytes()
    game, state, secondary, info, secs, secondary_time, scores, penalties = EXPECTED[name]
    p = parse_state_packet(data)
    assert (p.version, p.players_per_team, p.game_type) == (12, 6, 0)
    assert (p.state, p.secondary_state, p.secondary_state_info) == (state, secondary, info)
    assert p.first_half is True
    assert p.kick_off_team == 2
    assert (p.secs_remaining, p.secondary_time) == (secs, secondary_time)
    assert (p.drop_in_team, p.drop_in_time) == (0, 65535)
    assert tuple(t.team_number for t in p.teams) == game["teams"]
    for team in p.teams:
        assert team.team_color == game["colors"][team.team_number]
        assert team.score == scores[team.team_number]
        assert team.coach_text == ""
        for number, slot in enumerate(team.players, start=1):
            if number >= 5:
                assert slot.penalty == Penalty.SUBSTITUTE, (team.team_number, number)
            else:
                expected = penalties.get((team.team_number, number), (0, 0))
                assert (slot.penalty, slot.secs_till_unpenalized) == expected, (team.team_number, number)
            assert (slot.warnings, slot.yellow_cards, slot.red_cards) == (0, 0, 0)
        # substitute slots 5 and 6 (inside playersPerTeam 6) and unused 7..11 are not active robots
        assert sorted(team.active_players(p.players_per_team)) == [1, 2, 3, 4]
    assert build_state_packet(p) == data, "re-encoding must give the captured bytes back"


def test_gamestate_of_a_penalised_robot_and_its_teammates(testdata: Path) -> None:
    p = parse_state_packet((testdata / "gamecontroller" / "hl_v12_playing_red2_penalized.bin").read_bytes())
    me = gamestate_fields(p, team_number=2, player_number=2)
    assert me is not None
    assert me["penalized"] and me["seconds_till_unpenalized"] == 30 and not me["allowed_to_move"]
    assert me["has_kick_off"] and me["team_color"] == 1 and me["team_mates_with_penalty"] == []
    mate = gamestate_fields(p, team_number=2, player_number=1)
    assert mate is not None and not mate["penalized"] and mate["allowed_to_move"]
    assert mate["team_mates_with_penalty"] == [2]  # the substitutes 5 and 6 are not counted
    rival = gamestate_fields(p, team_number=3, player_number=1)
    assert rival is not None and not rival["has_kick_off"] and rival["team_color"] == 0
    assert gamestate_fields(p, team_number=9, player_number=1) is None


def test_free_kick_phases_freeze_or_free_the_robots(testdata: Path) -> None:
    folder = testdata / "gamecontroller"
    freeze = gamestate_fields(parse_state_packet((folder / "hl_v12_direct_free_kick.bin").read_bytes()), 2, 1)
    prepare = gamestate_fields(parse_state_packet((folder / "hl_v12_free_kick_manual_penalise.bin").read_bytes()),
                               2, 1)
    assert freeze is not None and prepare is not None
    keys = ("secondary_state_team", "secondary_state_mode", "allowed_to_move")
    assert tuple(freeze[k] for k in keys) == (2, 0, False)
    assert tuple(prepare[k] for k in keys) == (2, 1, True)
    assert (freeze["own_score"], freeze["rival_score"]) == (0, 1)
    assert prepare["team_mates_with_penalty"] == [2]


def test_spec_worked_example_round_trips() -> None:
    """The spec's example: 4 players, PLAYING, team 13 kicks off, 421 s, 1:0, player 3 penalised (34, 25 s)."""
    players = [RobotInfo(goalkeeper=True), RobotInfo(), RobotInfo(penalty=34, secs_till_unpenalized=25,
                                                                    yellow_cards=1)]
    data = GameControlData(packet_number=42, players_per_team=4, state=3, first_half=True, kick_off_team=13,
                           secs_remaining=421, teams=(TeamInfo(13, 0, 1, players=tuple(players)), TeamInfo(7, 1, 0)))
    raw = build_state_packet(data)
    assert len(raw) == PACKET_SIZE
    assert raw[:24] == bytes.fromhex("52 47 6d 65 0c 00 2a 04 00 03 01 0d 00 00 00 00 00 00 ff ff a5 01 00 00")
    assert raw[0x122:0x134] == bytes.fromhex("000000000001" "000000000000" "221900010000")
    assert raw[356:359] == bytes([7, 1, 0])
    back = parse_state_packet(raw)
    assert back.team(13).player(3) == RobotInfo(34, 25, 0, 1, 0, False)  # type: ignore[union-attr]
    assert back.team(13).player(1).goalkeeper  # type: ignore[union-attr]
    assert back.rival(13).team_number == 7  # type: ignore[union-attr]


def test_coach_message_and_cards_reach_the_gamestate() -> None:
    players = (RobotInfo(), RobotInfo(red_cards=1, penalty=Penalty.MANUAL), RobotInfo(yellow_cards=2),
               RobotInfo(), RobotInfo(red_cards=1, penalty=Penalty.SUBSTITUTE))
    data = GameControlData(players_per_team=5, state=3, teams=(
        TeamInfo(5, 1, 2, coach_message=b"press high\0junk", players=players), TeamInfo(6, 0, 3)))
    back = parse_state_packet(build_state_packet(data))
    fields = gamestate_fields(back, 5, 1)
    assert fields is not None
    assert fields["coach_message"] == "press high"
    assert fields["team_mates_with_red_card"] == [2]  # player 5 is a substitute
    assert fields["team_mates_with_penalty"] == [2]
    assert (fields["own_score"], fields["rival_score"]) == (2, 3)


def test_2018_form_with_four_byte_robot_info_is_read() -> None:
    top = bytes.fromhex("52 47 6d 65 0c 00 07 04 00 03 01 03 00 00 00 00 00 00 ff ff 2c 01 00 00")
    team = bytes([3, 1, 2, 0, 0, 0, 0]) + bytes(253) + bytes(4) + bytes([34, 20, 1, 0]) + bytes(4 * 10)
    raw = top + team + bytes([4, 0, 0, 0, 0, 0, 0]) + bytes(253) + bytes(48)
    assert len(raw) == PACKET_SIZE_2018
    p = parse_state_packet(raw)
    assert p.team(3).player(1) == RobotInfo(34, 20, 0, 1, 0, False)  # type: ignore[union-attr]
    assert p.secs_remaining == 300


def test_return_packet_is_byte_exact() -> None:
    assert build_return_packet(13, 3) == bytes.fromhex("52 47 72 74 02 0d 03 02")
    assert build_return_packet(2, 1, ReturnMessage.ALIVE) == b"RGrt\x02\x02\x01\x02"
    assert build_return_packet(2, 2, ReturnMessage.MAN_PENALISE) == b"RGrt\x02\x02\x02\x00"
    back = parse_return_packet(build_return_packet(2, 2, ReturnMessage.MAN_UNPENALISE))
    assert (back.team, back.player, back.message, back.version) == (2, 2, 1, 2)
    with pytest.raises(GameControllerPacketError, match="player number"):
        build_return_packet(2, 0)
    with pytest.raises(GameControllerPacketError, match="8 bytes"):
        parse_return_packet(b"RGrt\x02\x02\x01\x02\x00")
    with pytest.raises(GameControllerPacketError, match="version 4"):
        parse_return_packet(b"RGrt\x04" + bytes(27))


def _valid() -> bytearray:
    return bytearray(build_state_packet(GameControlData(teams=(TeamInfo(1, 0), TeamInfo(2, 1)))))


def test_wrong_header_is_rejected() -> None:
    raw = _valid()
    raw[:4] = b"RGrt"
    with pytest.raises(GameControllerPacketError, match="header"):
        parse_state_packet(raw)


@pytest.mark.parametrize(("version_bytes", "length", "named"), [
    (b"\x0b\x00", PACKET_SIZE, "version 11"),
    (b"\x0a\x00", 588, "version 10 (Humanoid League version 10"),
    (b"\x12\x07", 118, "version 18 (SPL"),
    (b"\x0c\x05", 54, "version 12 (SPL"),
    (b"\x15\x00", 158, "version 21"),
])
def test_other_versions_are_rejected_by_name(version_bytes: bytes, length: int, named: str) -> None:
    raw = bytearray(b"RGme" + version_bytes + bytes(length - 6))
    with pytest.raises(GameControllerPacketError, match=named.replace("(", r"\(")):
        parse_state_packet(raw)


@pytest.mark.parametrize("length", [0, 3, 24, 687, 689, 1000])
def test_wrong_size_is_rejected(length: int) -> None:
    raw = bytes(_valid()[:length]) if length <= PACKET_SIZE else bytes(_valid()) + bytes(length - PACKET_SIZE)
    with pytest.raises(GameControllerPacketError, match=r"size|short"):
        parse_state_packet(raw)


@pytest.mark.parametrize(("offset", "value", "what"), [
    (9, 7, "game state"), (10, 2, "first half"), (12, 42, "secondary state"), (7, 12, "players per team"),
    (25, 10, "team colour"),
])
def test_impossible_values_are_rejected(offset: int, value: int, what: str) -> None:
    raw = _valid()
    raw[offset] = value
    with pytest.raises(GameControllerPacketError, match=what):
        parse_state_packet(raw)


def test_build_refuses_what_cannot_be_sent() -> None:
    with pytest.raises(GameControllerPacketError):
        build_state_packet(GameControlData(secs_remaining=70000))
    with pytest.raises(GameControllerPacketError, match="coach message"):
        build_state_packet(GameControlData(teams=(TeamInfo(coach_message=bytes(300)), TeamInfo())))
    assert struct.unpack_from("<h", build_state_packet(GameControlData(secs_remaining=-5)), 20)[0] == -5
