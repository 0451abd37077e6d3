"""The HSL's Small division in simulation: ``pitchside match --players 4`` (Small Foundation, 4 v 4) plays both
halves in the suite; ``--players 7`` (Small Advanced, 7 v 7, 2 x 1 minute) is opt-in
(``PITCHSIDE_MATCH_7V7=1 ./run test tests/test_match_small.py``: 14 robots take about 10 minutes of a 2-core
machine, more than the suite has room for). Each match: every robot on the dashboard by telemetry only, both halves
in the HSL order, the GameController hearing every robot's status packet and counting both teams' messages against
the budget, every player of both teams on the pitch, and no robot left lying longer than the rules allow."""

from __future__ import annotations

import os
from pathlib import Path

import httpx
import pytest

from robot_nodes.sim.lineup import Lineup
from tests.match_log import GC_URL, MatchFigures, read_output
from tests.running_demo import running_demo
from tests.test_match import FALLEN_LIMIT_S, FINISHED, INITIAL, PLAYING, READY, SET, GameWatch, missing_gamestate
from tests.waiting import wait_for

SEVEN = os.environ.get("PITCHSIDE_MATCH_7V7", "") not in ("", "0")


@pytest.mark.slow
@pytest.mark.realtime
@pytest.mark.timeout(1800)
@pytest.mark.parametrize(("players", "half_minutes"), [
    pytest.param(4, 0.5, id="4v4"),
    pytest.param(7, 1.0, id="7v7", marks=pytest.mark.skipif(not SEVEN, reason="opt-in: PITCHSIDE_MATCH_7V7=1")),
])
def test_a_small_division_match_plays_both_halves(players: int, half_minutes: float, tmp_path: Path,
                                                  recordings_elsewhere: Path) -> None:
    robots = tuple(Lineup.of((1, 2), (players, players)).robot_ids())
    args = ("--players", str(players), "--half-minutes", str(half_minutes), "--ready-seconds", "10",
            "--set-seconds", "1", "--initial-seconds", "2", "--half-time-seconds", "3")
    with running_demo(tmp_path, *args, command="match") as match:
        gc_url = GC_URL.search(match.output())
        assert gc_url, match.output()
        api = gc_url.group(1)
        watch = GameWatch(match.ws_url, ("gamestate",))
        with watch:
            wait_for(lambda: all(watch.newest(r) for r in robots), 300,
                     what=lambda: missing_gamestate(watch, robots, match.output()))
            # every robot's last telemetry of the game (each robot's datagrams come on their own)
            END = [(FINISHED, False)]
            wait_for(lambda: all(watch.states(r)[-1:] == END for r in robots),
                     4 * half_minutes * 60 + 600,
                     what=lambda: f"the end of the game at {[r for r in robots if watch.states(r)[-1:] != END]}")
            assert watch.error == "" and watch.sources == {"telemetry"}  # match mode: one-way telemetry only
            for robot in robots:  # every robot saw the game, its halves in the HSL order
                states = watch.states(robot)
                second = [s for s, h in states if not h]
                assert second[-1] == FINISHED and second.index(PLAYING) > second.index(SET) > second.index(READY)
                assert (INITIAL, False) in states and (PLAYING, True) in states, (robot, states)
        status = httpx.get(f"{api}/status", timeout=10).json()
        output = match.output()
    assert status["version"] == 20 and status["state"] == "FINISHED" and not status["first_half"]
    # the first INITIAL waited until every robot of the lineup had sent its v4 status packet
    assert "every player heard after" in output and "starting without return packets" not in output
    assert {(r["team"], r["player"]) for r in status["returns"]} <= {(t, p) for t in (1, 2)
                                                                      for p in range(1, players + 1)}
    for team in status["teams"]:
        assert team["team_messages"] > 0 and team["illegal_messages"] == 0, team
        assert 0 < team["message_budget"] < 12_000, team
        playing = [p for p in team["players"] if p["number"] <= players]
        assert all(p["penalty"] != 14 for p in playing), team  # no player of the lineup a substitute
    assert f"match {players}v{players}" in output
    play = MatchFigures(seed=0)
    read_output(output, play)
    print(f"{players} v {players}: kicks {play.kicks}, falls {play.falls}, get-ups {play.get_ups}, penalties "
          f"{play.penalties}, longest time down {play.longest_down_s:.1f} s")
    assert play.longest_down_s <= FALLEN_LIMIT_S, (play.fall_to_up_s, play.still_down_s)
