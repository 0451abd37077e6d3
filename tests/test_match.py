"""`pitchside match` as a real process tree: two teams in the world, the simulated GameController running the
Humanoid League flow on fast halves, every robot's nodes, the dashboard in match mode hearing telemetry only and
recording each half; the recordings open in the replay source."""

from __future__ import annotations

import asyncio
import os
import socket
import threading
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import httpx
import psutil
import pytest

from pitchside.local_run import BEHIND_THE_WORLD_NICE, ROBOTS_IN_MATCH_NICE, DashboardPlan
from pitchside.match import (
    MATCH_TELEMETRY_RATES_HZ,
    GameControllerPlan,
    MatchPlan,
    default_nodes,
    match_processes,
    parse_nodes,
    robot_settings,
)
from pitchside.match import main as match_main
from robot_nodes.runtime.clock import SIM_TIME_ENV
from robot_nodes.sim.gamecontroller import SimulatedGame, SimulatedGameController
from robot_nodes.sim.lineup import Lineup, LineupError, parse_robots
from robot_nodes.telemetry.sender import DEFAULT_TOPICS, parse_topics
from schemas.logs import LogSeriesReader
from server.hub import Hub
from server.sources.replay import ReplaySource
from tests.match_log import GC_URL, MatchFigures, read_output
from tests.running_demo import DashboardObserver, running_demo
from tests.support import free_port
from tests.waiting import wait_for

PORTS = DashboardPlan(5800, 5801, 5802, 5803)  # the telemetry ports and the recorder's control port of a plan
INITIAL, READY, SET, PLAYING, FINISHED = range(5)
ROBOTS = ("home1", "home2", "away1", "away2")
# the suite plays fast halves (2 x 18 s, READY 3 s: the flow, not the play); PITCHSIDE_MATCH_HALF_MINUTES=2 plays
# the 2 x 2 minutes with READY 20 s (about 6 minutes; the suite's 15-minute budget has no room for it)
HALF_MINUTES = float(os.environ.get("PITCHSIDE_MATCH_HALF_MINUTES", "0.3"))
READY_S = 3 if HALF_MINUTES < 1 else 20
FALLEN_LIMIT_S = 20.0  # a robot lying (its HCM in FALLEN) is up again, or penalised by the referee, within this


@dataclass
class GameWatch(DashboardObserver):
    """Every gamestate the dashboard shows, in order (robot, game_state, first_half, own, rival, kick-off)."""

    history: list[tuple[str, int, bool, int, int, bool]] = field(default_factory=list)
    sources: set[str] = field(default_factory=set)
    _lock: threading.Lock = field(default_factory=threading.Lock)

    def _seen(self, frame: dict[str, Any]) -> None:
        super()._seen(frame)
        if frame["topic"] != "gamestate":
            return
        d = frame["data"]
        with self._lock:
            self.sources.add(frame["source"])
            self.history.append((frame["robot"], d["game_state"], d["first_half"], d["own_score"], d["rival_score"],
                                 d["has_kick_off"]))

    def states(self, robot: str) -> list[tuple[int, bool]]:
        """The robot's (game state, first half) in the order they came, repeats dropped."""
        with self._lock:
            seen = [(s, h) for r, s, h, *_ in self.history if r == robot]
        return [x for i, x in enumerate(seen) if i == 0 or seen[i - 1] != x]

    def newest(self, robot: str) -> tuple[str, int, bool, int, int, bool] | None:
        with self._lock:
            return next((h for h in reversed(self.history) if h[0] == robot), None)

    def heard(self, robot: str) -> list[int] | None:
        """The teammates the robot hears, as its newest team_comm on the dashboard says."""
        frame = self.get(robot, "team_comm")
        return None if frame is None else list(frame["data"]["mate_ids"])

    def sees(self, robot: str, condition: Callable[[tuple[str, int, bool, int, int, bool]], bool]) -> bool:
        """The robot's newest gamestate holds ``condition``."""
        newest = self.newest(robot)
        return newest is not None and condition(newest)


def test_times_down_are_counted_in_the_simulations_seconds_when_the_robots_follow_it() -> None:
    """Wall stamps a minute apart, simulated times 12 s apart: a slow world's robot lay 12 s, not 60. A robot lies
    from its HCM's FALLEN (the fall before it is not lying) until it stands or the referee penalises it."""
    output = "\n".join([
        "2026-11-27 15:59:00,000 INFO [match world] match 2v2: team 1 (home1, home2) against team 2 (away1, away2), "
        "refereed by the simulated GameController",
        "2026-11-27 16:00:00,000 INFO [pitchside.home1.hcm] CONTROLLABLE -> FALLING (falling) at sim 30.00 s",
        "2026-11-27 16:00:01,000 INFO [pitchside.home1.hcm] FALLING -> FALLEN (fallen) at sim 30.40 s",
        "2026-11-27 16:00:02,000 INFO [pitchside.home1.hcm] FALLEN -> GETTING_UP (get up) at sim 30.60 s",
        "2026-11-27 16:00:03,000 INFO [pitchside.home1.hcm] GETTING_UP -> FALLEN (left lying) at sim 33.00 s",
        "2026-11-27 16:00:04,000 INFO [pitchside.home1.hcm] FALLEN -> GETTING_UP (get up) at sim 33.10 s",
        "2026-11-27 16:00:20,000 INFO [pitchside.home1.kick] kick with the left foot: ball at (0.3, 0.0)",
        "2026-11-27 16:00:25,000 INFO [pitchside.home1.kick] strike with the left foot 5.1 s after the goal came",
        "2026-11-27 16:00:28,000 INFO [pitchside.home1.kick] kick aborted: the ball did not go: seen within 0.25 m",
        "2026-11-27 16:00:40,000 INFO [pitchside.away1.kick] kick with the right foot: ball at (0.4, 0.1)",
        "2026-11-27 16:00:45,000 INFO [pitchside.away1.kick] kick aborted: ball not seen for 3.0 s",
        "2026-11-27 16:01:00,000 INFO [pitchside.home1.hcm] GETTING_UP -> CONTROLLABLE (up) at sim 42.00 s",
        "2026-11-27 16:01:01,000 INFO [pitchside.away2.hcm] WALKING -> FALLING (falling) at sim 42.50 s",
        "2026-11-27 16:01:02,000 INFO [pitchside.away2.hcm] FALLING -> FALLEN (fallen) at sim 43.50 s",
        "2026-11-27 16:01:03,000 INFO [pitchside.home2.hcm] WALKING -> FALLING (falling) at sim 44.00 s",
        "2026-11-27 16:02:00,000 INFO [match world] referee at 63.5 s: penalty team 2 player 2 (lay for 20 s)",
        "2026-11-27 16:02:00,000 INFO [match world] referee at 63.5 s: removed team 2 player 2 (penalty 34)",
        "2026-11-27 16:02:01,000 INFO [pitchside.away2.hcm] FALLEN -> PENALTY (penalized) at sim 64.00 s",
    ])
    play = MatchFigures(seed=0)
    read_output(output, play)
    assert (play.falls, play.get_ups, play.kicks, play.strikes, play.penalties) == (3, 2, 2, 1, 1)
    assert play.kick_outcomes == {"aborted: the ball did not go": 1, "aborted: ball not seen for N s": 1}
    assert play.fall_to_up_s == pytest.approx([11.6, 20.0])  # home1 stood; away2 penalised by the referee
    assert play.falling_to_up_s == pytest.approx([12.0, 21.5])  # from FALLING until standing or the HCM's PENALTY
    assert play.still_down_s == pytest.approx([20.0])  # home2, never FALLEN: from FALLING until the last line
    wall = MatchFigures(seed=0)
    read_output(output.replace(" at sim", " at wall"), wall)  # an HCM on the wall clock: the lines' stamps
    assert wall.fall_to_up_s == pytest.approx([59.0, 58.0])


def test_lineup_and_robot_settings() -> None:
    assert parse_robots("4v4") == (4, 4) and parse_robots("2V3") == (2, 3)
    for bad in ("4", "0v1", "12v1", "av b"):
        with pytest.raises(LineupError):
            parse_robots(bad)
    lineup = Lineup.of((5, 9), (3, 2))
    assert lineup.robot_ids() == ["home1", "home2", "home3", "away1", "away2"]
    assert lineup.member("away2") == (lineup.away, 2) and lineup.member("away3") is None
    with pytest.raises(LineupError, match="different team numbers"):
        Lineup.of((4, 4), (1, 1))
    ports = {r: 4000 + i for i, r in enumerate(lineup.robot_ids())}
    sim = GameControllerPlan("sim", 3838, 3939, 8038)
    home2 = robot_settings(lineup.home, 2, sim, ports, 5800, None)
    assert "listen_address=127.255.255.255" in home2["game_controller"]  # hears the loopback broadcast only
    assert "team_number=5" in home2["game_controller"] and "player_number=2" in home2["game_controller"]
    assert "peers=127.0.0.1:4000,127.0.0.1:4002" in home2["mitecom"] and "port=4001" in home2["mitecom"]
    # with the simulated GameController counting them: HSL team messages, broadcast on loopback to the team's port
    hsl = GameControllerPlan("sim", 3838, 3939, 8038, {5: 6005, 9: 6009})
    away1 = robot_settings(lineup.away, 1, hsl, ports, 5800, None, half_s=120)["mitecom"]
    assert {"hsl=true", "team_port=6009", "broadcast_address=127.255.255.255", "half_s=120"} <= set(away1)
    assert not any(a.startswith("peers=") for a in away1)
    # a match's dashboard gets joints, IMU, HCM state and diagnostics at half the lab's rates (pose and ball not)
    rates = parse_topics(next(a for a in home2["telemetry"] if a.startswith("topics=")).split("=", 1)[1])
    assert rates | MATCH_TELEMETRY_RATES_HZ == rates and rates.keys() == parse_topics(DEFAULT_TOPICS).keys()
    assert rates["joint_states"] == 5 and rates["position"] == rates["ball_relative"] == 10
    # one field frame for both teams' stand-in localizations: the away team defends its +x half
    assert home2["behavior"] == home2["head"] == ["--set", "own_half=-x"]
    assert robot_settings(lineup.away, 1, sim, ports, 5800, None)["behavior"] == ["--set", "own_half=+x"]
    assert "own_half=+x" in robot_settings(lineup.away, 1, sim, ports, 5800, None)["game_controller"]  # status pose
    external = GameControllerPlan("external", 3838, 3939, None)
    assert "listen_address=0.0.0.0" in robot_settings(lineup.away, 1, external, ports, 5800, None)["game_controller"]
    assert not any(a.startswith("peers=") for a in robot_settings(Lineup.of((1, 2), (1, 1)).home, 1, sim,
                                                                  {"home1": 1, "away1": 2}, 5800, None)["mitecom"])
    assert {"game_controller", "mitecom", "telemetry", "hcm", "walking"} <= set(default_nodes())
    assert parse_nodes("hcm, walking") == ["hcm", "walking"]
    with pytest.raises(ValueError, match="cm730 runs in the world"):
        parse_nodes("cm730,hcm")
    with pytest.raises(ValueError, match="nosuchnode"):
        parse_nodes("hcm,nosuchnode")
    for bad in (["--players", "7", "--robots", "2v2"], ["--players", "12"]):  # refused before anything starts
        with pytest.raises(SystemExit) as exited:
            match_main(bad)
        assert exited.value.code == 2


def test_the_world_waits_for_every_robot_unless_told_not_to() -> None:
    """pitchside match: lockstep by default (the world's --lockstep, the robots' PITCHSIDE_SIM_TIME=lockstep);
    --no-lockstep keeps simulated time without it; --wall-clock has neither."""
    lineup = Lineup.of((1, 2), (2, 1))
    plan = MatchPlan(lineup, ["hcm", "walking"], 60, 45.0, 5.0, 5.0, 30.0, 1, 0, "all", "minibot")
    ports = {r: 4000 + i for i, r in enumerate(lineup.robot_ids())}

    def clocks(plan: MatchPlan) -> tuple[list[str], set[str | None]]:
        processes = match_processes(plan, endpoint="tcp/127.0.0.1:7447", http_port=8080, dashboard=PORTS,
                                    gc=GameControllerPlan("sim", 3838, 3939, 1), mitecom_ports=ports, token="token",
                                    telemetry_key=None)
        world = next(p for p in processes if p.name == "world")
        robots = [p for p in processes if p.name not in ("world", "server", "recorder")]
        assert len(robots) == 3  # composed: one process a robot
        return [a for a in world.argv if a in ("--sim-time", "--lockstep")], {p.env.get(SIM_TIME_ENV) for p in robots}

    assert clocks(plan) == (["--sim-time", "--lockstep"], {"lockstep"})
    assert clocks(replace(plan, lockstep=False)) == (["--sim-time"], {"1"})
    assert clocks(replace(plan, sim_time=False, lockstep=False)) == ([], {None})
    # a team's robots sharing a process (the command's default): each such process follows the simulated clock too
    shared = match_processes(replace(plan, robots_per_process=4), endpoint="tcp/127.0.0.1:7447", http_port=8080,
                             dashboard=PORTS, gc=GameControllerPlan("sim", 3838, 3939, 1), mitecom_ports=ports,
                             token="token", telemetry_key=None)
    robots = [p for p in shared if p.name not in ("world", "server", "recorder")]
    assert [p.name for p in robots] == ["home1+home2", "away1/hcm+walking"]
    assert robots[0].members == ["home1/hcm", "home1/walking", "home2/hcm", "home2/walking"]
    assert {p.env.get(SIM_TIME_ENV) for p in robots} == {"lockstep"}


def missing_gamestate(watch: GameWatch, robots: tuple[str, ...], output: str) -> str:
    """What a wait for every robot's gamestate says when it times out: who is missing, what the match printed last."""
    missing = [r for r in robots if watch.newest(r) is None]
    tail = "\n".join(output.splitlines()[-60:])
    return f"every robot's gamestate on the dashboard: none from {missing}; the match printed last:\n{tail}"


def assert_world_first(processes: list[psutil.Process]) -> None:
    """The world (physics, referee, GameController) at the launcher's priority, every robot's nodes below it, the
    dashboard between (pitchside/local_run.py ROBOTS_IN_MATCH_NICE, BEHIND_THE_WORLD_NICE)."""
    launcher = processes[0].nice()
    modules = {}
    for process in processes[1:]:
        try:
            command, nice = process.cmdline(), process.nice()
        except psutil.NoSuchProcess:  # a short-lived child that ended meanwhile (the server's graphviz layout)
            continue
        if command[1:2] == ["-m"]:
            modules[command[2]] = nice
    assert modules.pop("robot_nodes.sim.match") == launcher, modules
    assert modules.pop("server") == launcher + BEHIND_THE_WORLD_NICE, modules
    assert modules.pop("server.recording") == launcher + BEHIND_THE_WORLD_NICE, modules
    assert "robot_nodes.compose" in modules, modules
    assert set(modules.values()) == {launcher + ROBOTS_IN_MATCH_NICE}, modules


# The matches run in ./run test's realtime process, one after another with the simulations: on a worker, beside
# chromium and a simulation at nice -5, the robots' processes (nice 10) starved at start-up, and no gamestate came
# within 60 s (CI, 2 cores)
@pytest.mark.slow
@pytest.mark.realtime
@pytest.mark.timeout(900)
def test_a_match_plays_both_halves_under_the_gamecontroller_and_records_them(tmp_path: Path,
                                                                             recordings_elsewhere: Path) -> None:
    """2 v 2, two halves of HALF_MINUTES: the GameController's whole flow (a goal pressed in it, as an operator
    would), every robot's data on the dashboard by telemetry only, each half recorded and replayable, and on the
    pitch: every robot that fell stood up again or was penalised within FALLEN_LIMIT_S."""
    before = set(recordings_elsewhere.glob("match-*.mcap"))
    args = ("--robots", "2v2", "--half-minutes", str(HALF_MINUTES), "--ready-seconds", str(READY_S),
            "--set-seconds", "1", "--initial-seconds", "2", "--half-time-seconds", "3")
    with running_demo(tmp_path, *args, command="match") as match:
        gc_url = GC_URL.search(match.output())
        assert gc_url, match.output()
        api = gc_url.group(1)
        watch = GameWatch(match.ws_url, ("gamestate", "team_comm"))
        with watch:
            wait_for(lambda: all(watch.newest(r) for r in ROBOTS), 60,
                     what=lambda: missing_gamestate(watch, ROBOTS, match.output()))
            assert_world_first(match.processes())
            wait_for(lambda: watch.heard("home1") == [2] and watch.heard("away2") == [1], 30,
                     what="whom each robot hears (team_comm, by telemetry)")
            colours = {r: watch.get(r, "gamestate")["data"]["team_color"] for r in ROBOTS}  # type: ignore[index]
            assert colours == {"home1": 0, "home2": 0, "away1": 1, "away2": 1}  # as the GameController sends them
            wait_for(lambda: watch.sees("home1", lambda h: h[1] == PLAYING), 60, what="first kick-off")
            assert httpx.post(f"{api}/goal", json={"team": 1}, timeout=10).status_code == 200
            wait_for(lambda: watch.sees("away1", lambda h: h[1] == READY and h[4] == 1), 20,
                     what="READY after the goal, seen by the other team")
            assert watch.sees("away1", lambda h: h[5])  # the away team kicks off
            wait_for(lambda: watch.sees("home1", lambda h: h[3] == 1 and not h[5]), 10, what="home's score")
            wait_for(lambda: watch.states("home1")[-1:] == [(FINISHED, False)], 4 * HALF_MINUTES * 60 + 120,
                     what="the end of the game")
            states = watch.states("home1")
            assert watch.error == "" and watch.sources == {"telemetry"}  # match mode: one-way telemetry only
        status = httpx.get(f"{api}/status", timeout=10).json()
        answered = {(r["team"], r["player"]) for r in status["returns"]}
        assert status["return_count"] > 20 and answered == {(1, 1), (1, 2), (2, 1), (2, 2)}
        # HSL v20 and the team messages the HSL way: broadcast to each team's port, counted against its budget
        assert status["version"] == 20
        for team in status["teams"]:
            assert team["team_messages"] > 0 and team["illegal_messages"] == 0, team
            assert 0 < team["message_budget"] < 12_000, team
        output = match.output()
        # the referee is in the world; what it calls depends on the play (tests/test_referee.py judges each call)
        assert "refereed by the simulated GameController" in output
    play = MatchFigures(seed=0)
    read_output(output, play)
    print(f"match: kicks {play.kicks}, falls {play.falls}, get-ups {play.get_ups}, penalties {play.penalties}, "
          f"placed at SET {play.placed}, longest time down {play.longest_down_s:.1f} s")
    assert play.longest_down_s <= FALLEN_LIMIT_S, (play.fall_to_up_s, play.still_down_s)
    for half in (True, False):  # every state of both halves, in the Humanoid League order
        order = [s for s, h in states if h == half]
        for state in (INITIAL, READY, SET, PLAYING, FINISHED) if not half else (READY, SET, PLAYING, FINISHED):
            assert state in order, f"{'first' if half else 'second'} half: {states}"
    first = [s for s, h in states if h]
    assert first.index(FINISHED) > first.index(PLAYING) > first.index(SET) > first.index(READY)
    assert (INITIAL, False) in states and states.index((INITIAL, False)) > states.index((FINISHED, True))
    assert first.count(READY) >= 2  # kick-off, then again after the goal

    files = sorted(set(recordings_elsewhere.glob("match-*.mcap")) - before)
    assert [f.name.rsplit("_", 1)[-1] for f in files] == ["half1.mcap", "half2.mcap"], files
    for path, first_half in zip(files, (True, False), strict=True):
        with LogSeriesReader(path) as log:
            states_in_file = {(m.robot_id, int(m.msg.game_state), bool(m.msg.first_half))
                              for m in log.messages(topics=["gamestate"])}
            marks = [b.name for b in log.bookmarks]
        if first_half:
            assert "goal blue 1:0" in marks, marks  # one goal, named by the scorer's colour (both teams heard)
        assert {r for r, _, _ in states_in_file} >= set(ROBOTS)
        assert {h for _, _, h in states_in_file} == {first_half}  # each half in its own file
        assert (PLAYING in {s for _, s, _ in states_in_file})

    async def replay(path: Path) -> dict[str, Any]:
        hub = Hub()
        hub.bind(asyncio.get_running_loop())
        source = ReplaySource(hub, path.parent)
        info = await source.open(path.name)
        await source.seek(info["duration_s"] / 2)
        await source.close()
        return info

    for path in files:
        info = asyncio.run(replay(path))
        assert set(info["robots"]) >= {f"replay.{r}" for r in ROBOTS} and info["duration_s"] > 10


@pytest.mark.slow
@pytest.mark.realtime
def test_a_real_gamecontroller_on_the_network_referees_every_robot(tmp_path: Path) -> None:
    """--gamecontroller external: a GameController elsewhere (here one in this test, broadcasting as on a field)
    reaches every robot of the match on this machine; each answers it; the world's referee follows its game."""
    gc_port, return_port = free_port(socket.SOCK_DGRAM), free_port(socket.SOCK_DGRAM)
    game = SimulatedGame(teams=(7, 3), team_colors=(1, 0), players_per_team=2, initial_s=0, auto_progress=False)
    real = SimulatedGameController(game, [("127.255.255.255", gc_port)], ("127.0.0.1", return_port))
    args = ("--robots", "2v1", "--teams", "3", "7", "--gamecontroller", "external", "--gc-port", str(gc_port),
            "--gc-return-port", str(return_port), "--nodes", "hcm,pause,game_controller,mitecom,telemetry")
    with real, running_demo(tmp_path, *args, command="match") as match:
        watch = GameWatch(match.ws_url, ("gamestate",))
        with watch:
            robots = ("home1", "home2", "away1")
            wait_for(lambda: all(watch.newest(r) for r in robots), 60,
                     what=lambda: missing_gamestate(watch, robots, match.output()))
            colours = {r: watch.get(r, "gamestate")["data"]["team_color"] for r in robots}  # type: ignore[index]
            assert colours == {"home1": 0, "home2": 0, "away1": 1}  # team 3 blue, team 7 red, as it says
            wait_for(lambda: {(r.packet.team, r.packet.player) for r in real.returns} == {(3, 1), (3, 2), (7, 1)},
                     20, what="return packets of every robot")
            real.set_state("ready")
            real.set_state("set")
            wait_for(lambda: "placed team 7 player 1" in match.output(), 30, what="the referee places robots at SET")
            wait_for(lambda: watch.sees("away1", lambda h: h[1] == SET), 20, what="SET on the dashboard")
        assert "refereed by the external GameController" in match.output()
