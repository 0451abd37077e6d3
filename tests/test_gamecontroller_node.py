"""Simulated GameController -> game_controller node over real UDP on loopback -> `gamestate` over Zenoh."""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator
from typing import Any

import httpx
import pytest

import schemas
from robot_nodes.game_controller.receiver import GameControllerNode, gamestate_fields
from robot_nodes.runtime import BusConfig, Node
from robot_nodes.sim.gamecontroller import SimulatedGame, SimulatedGameController
from tests.support import free_port
from tests.waiting import wait_for
from wire.gamecontroller.packets import (
    GameControlData,
    Penalty,
    RobotInfo,
    StatusPacket,
    TeamInfo,
    build_state_packet,
    parse_state_packet,
)

ROBOT = "gc_robot"


class GameStateWatcher(Node):
    """Collects what the game_controller node publishes, as any other node of the robot would."""

    name = "gamestate_watcher"

    def setup(self) -> None:
        self.lock = threading.Lock()
        self.states: list[Any] = []
        self.gc_diagnostics: dict[str, str] = {}
        self.subscribe("gamestate", self._on_gamestate)
        self.subscribe("diagnostics", self._on_diagnostics)

    def _on_gamestate(self, msg: Any) -> None:
        with self.lock:
            self.states.append(msg)

    def _on_diagnostics(self, msg: Any) -> None:
        for status in msg.status:
            if status.name.endswith("/game_controller"):
                self.gc_diagnostics = {kv.key: kv.value for kv in status.values}

    def latest(self, condition: Any = None) -> Any:
        with self.lock:
            for msg in reversed(self.states):
                if condition is None or condition(msg):
                    return msg
        return None


@pytest.fixture
def gc_port() -> int:
    return free_port(socket.SOCK_DGRAM)


@pytest.fixture
def return_port() -> int:
    return free_port(socket.SOCK_DGRAM)


@pytest.fixture
def node(bus: BusConfig, gc_port: int, return_port: int) -> Iterator[GameControllerNode]:
    n = GameControllerNode(robot_id=ROBOT, bus=bus, overrides={
        "team_number": 5, "player_number": 2, "listen_address": "127.0.0.1", "listen_port": gc_port,
        "return_port": return_port,
    }).start()
    yield n  # type: ignore[misc]
    n.shutdown()


@pytest.fixture
def watcher(bus: BusConfig) -> Iterator[GameStateWatcher]:
    w = GameStateWatcher(robot_id=ROBOT, bus=bus).start()
    yield w  # type: ignore[misc]
    w.shutdown()


def test_simulated_game_reaches_the_robot(node: GameControllerNode, watcher: GameStateWatcher, gc_port: int,
                                          return_port: int) -> None:
    game = SimulatedGame(teams=(6, 5), team_colors=(0, 1), players_per_team=4, initial_s=0.5, ready_s=1.0,
                         set_s=0.5, half_s=600)
    with SimulatedGameController(game, [("127.0.0.1", gc_port)], ("127.0.0.1", return_port)) as gc:
        http_port = gc.serve_http(0)
        api = f"http://127.0.0.1:{http_port}"
        initial = wait_for(lambda: watcher.latest(), 15, what="first gamestate")
        assert initial.team_color == 1 and not initial.has_kick_off and initial.first_half
        for state in (1, 2, 3):  # READY, SET, PLAYING by the simulator's clock
            wait_for(lambda s=state: watcher.latest(lambda m: m.game_state == s), 20, what=f"game state {state}")
        playing = watcher.latest(lambda m: m.game_state == 3)
        assert playing.allowed_to_move and not playing.penalized and 590 <= playing.seconds_remaining <= 600

        # penalise this robot (team 5 player 2) through the HTTP API
        r = httpx.post(f"{api}/penalize", json={"team": 5, "player": 2, "seconds": 20}, timeout=10)
        assert r.status_code == 200, r.text
        msg = wait_for(lambda: watcher.latest(lambda m: m.penalized), 10, what="penalised gamestate")
        assert 1 <= msg.seconds_till_unpenalized <= 20 and not msg.allowed_to_move
        # a teammate penalised from the command line, a goal, then unpenalise
        assert gc.execute("penalize 5 3 0") == "ok"
        assert httpx.post(f"{api}/goal", json={"team": 5}, timeout=10).status_code == 200
        msg = wait_for(lambda: watcher.latest(lambda m: m.own_score == 1 and list(m.team_mates_with_penalty) == [3]
                                              and m.game_state == 1), 10, what="goal, READY again, teammate penalty")
        assert msg.rival_score == 0
        assert httpx.post(f"{api}/unpenalize", json={"team": 5, "player": 2}, timeout=10).status_code == 200
        wait_for(lambda: watcher.latest(lambda m: not m.penalized and m.own_score == 1), 10, what="unpenalised")
        assert httpx.post(f"{api}/state", json={"state": "finished"}, timeout=10).status_code == 200
        wait_for(lambda: watcher.latest(lambda m: m.game_state == 4), 10, what="FINISHED")
        bad = httpx.post(f"{api}/penalize", json={"team": 9, "player": 1}, timeout=10)
        assert bad.status_code == 400 and "team 9" in bad.json()["error"]

        # status packets (RGrt v4: the simulated GC speaks HSL v20) from team 5 player 2 arrive at about 2 Hz
        wait_for(lambda: len(gc.returns_from(5, 2)) >= 6, 15, what="six return packets")
        returns = gc.returns_from(5, 2)
        assert all(r.address[0] == "127.0.0.1" and isinstance(r.packet, StatusPacket) for r in returns)
        assert initial.version == 20 and initial.message_budget == 12_000
        span = returns[-1].time - returns[0].time
        rate = (len(returns) - 1) / span
        assert 1.0 <= rate <= 4.0, f"return packets at {rate:.2f} Hz"
        status = httpx.get(f"{api}/status", timeout=10).json()
        assert status["state"] == "FINISHED" and status["return_count"] >= 6
        assert any(r["team"] == 5 and r["player"] == 2 and r["message"] == "STATUS" and r["fallen"] == 255
                   for r in status["returns"])


def test_every_field_reaches_the_gamestate(node: GameControllerNode, watcher: GameStateWatcher,
                                           gc_port: int) -> None:
    own = TeamInfo(5, 1, 3, penalty_shot=2, single_shots=0b101, coach_message=b"go left",
                   players=(RobotInfo(), RobotInfo(penalty=Penalty.PHYSICAL_CONTACT, secs_till_unpenalized=17),
                            RobotInfo(penalty=Penalty.MANUAL), RobotInfo(red_cards=1, penalty=Penalty.SERVICE,
                                                                        secs_till_unpenalized=40),
                            RobotInfo(penalty=Penalty.SUBSTITUTE, red_cards=1)))
    data = GameControlData(players_per_team=5, state=3, first_half=False, kick_off_team=5, secondary_state=5,
                           secondary_state_info=(5, 1, 0, 0), drop_in_team=5, drop_in_time=12, secs_remaining=-3,
                           secondary_time=17, teams=(TeamInfo(6, 0, 1), own))
    raw = build_state_packet(data)
    expected = gamestate_fields(parse_state_packet(raw), 5, 2)
    assert expected is not None
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        msg = wait_for(lambda: s.sendto(raw, ("127.0.0.1", gc_port)) and watcher.latest(), 10, interval=0.2,
                       what="gamestate from a crafted packet")
    got = {k: v for k, v in schemas.to_dict(msg).items() if k in expected}
    assert got == expected
    fields = {k for k in schemas.to_dict(msg) if not k.isupper() and not k.startswith("__")}
    assert set(expected) | {"header"} == fields, "a GameState field is not filled"
    assert got["penalized"] and got["seconds_till_unpenalized"] == 17 and got["team_mates_with_penalty"] == [3, 4]
    assert got["team_mates_with_red_card"] == [4] and got["coach_message"] == "go left"
    assert got["seconds_remaining"] == -3 and got["drop_in_team"] and got["secondary_state"] == 5


def test_garbage_is_counted_and_the_node_keeps_working(node: GameControllerNode, watcher: GameStateWatcher,
                                                        gc_port: int, return_port: int) -> None:
    game = SimulatedGame(teams=(5, 6), initial_s=0, auto_progress=False)
    garbage = [b"", b"RGme", b"RGme\x0b\x00" + bytes(682), b"\xff" * 688, b"RGme\x0c\x00" + bytes(100),
               b"RGrt\x02\x05\x02\x02", bytes(range(256)) * 3]
    with SimulatedGameController(game, [("127.0.0.1", gc_port)], ("127.0.0.1", return_port)) as gc:
        wait_for(lambda: watcher.latest(), 15, what="first gamestate")
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            for _ in range(3):
                for g in garbage:
                    s.sendto(g, ("127.0.0.1", gc_port))
        wait_for(lambda: node.bad_packets >= 3 * len(garbage), 10, what="garbage counted")
        gc.set_state("playing")
        gc.goal(6)  # READY again, the kick-off is ours
        msg = wait_for(lambda: watcher.latest(lambda m: m.rival_score == 1 and m.game_state == 1), 10,
                       what="state after garbage")
        assert msg.has_kick_off and msg.own_score == 0
        diag = wait_for(lambda: watcher.gc_diagnostics.get("bad_packets") == str(3 * len(garbage))
                        and watcher.gc_diagnostics, 10, what="bad_packets in diagnostics")
        assert int(diag["packets"]) >= 1
        # a packet for other teams only is ignored without an error
        other = build_state_packet(GameControlData(teams=(TeamInfo(7), TeamInfo(8))))
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.sendto(other, ("127.0.0.1", gc_port))
        wait_for(lambda: node.foreign_packets >= 1, 10, what="foreign packet counted")
        assert node.bad_packets == 3 * len(garbage)


def test_simulator_plays_both_halves_and_takes_manual_penalties() -> None:
    game = SimulatedGame(teams=(3, 4), players_per_team=2, initial_s=0.2, ready_s=0.2, set_s=0.2, half_s=1,
                         half_time_s=0.2, version=12)
    nowhere = ("127.0.0.1", free_port(socket.SOCK_DGRAM))
    with SimulatedGameController(game, [nowhere], ("127.0.0.1", 0), rate_hz=10.0) as gc:
        assert gc.status()["teams"][0]["players"][2]["penalty"] == Penalty.SUBSTITUTE  # beyond playersPerTeam
        wait_for(lambda: not gc.status()["first_half"], 15, what="second half")
        assert gc.status()["kick_off_team"] == 4
        wait_for(lambda: gc.status()["state"] == "FINISHED", 15, what="end of the game")
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.sendto(b"RGrt\x02\x04\x02\x00", ("127.0.0.1", gc.return_port))  # team 4 player 2: MAN_PENALISE
            s.sendto(b"RGrt\x07junk", ("127.0.0.1", gc.return_port))
        wait_for(lambda: gc.status()["teams"][1]["players"][1]["penalty"] == Penalty.MANUAL, 10,
                 what="manual penalty from a return packet")
        wait_for(lambda: gc.bad_returns == 1, 10, what="bad return packet counted")
        packet = parse_state_packet(gc.tick())
        assert packet.team(4).player(2).penalty == Penalty.MANUAL  # type: ignore[union-attr]
        assert gc.execute("unpenalize 4 2") == "ok" and gc.execute("goal 9").startswith("error: team 9")
        assert parse_state_packet(gc.tick()).team(4).player(2).penalty == 0  # type: ignore[union-attr]


def test_hsl_v20_reaches_the_gamestate_and_bad_input_is_named(node: GameControllerNode, watcher: GameStateWatcher,
                                                               gc_port: int) -> None:
    from tests.test_gamecontroller_hsl import spec_packet
    # the node is team 5 player 2: a v20 packet where team 13 is renumbered 5
    raw = bytearray(spec_packet(own={2: (3, 0, 1)}, stopped=1, set_play=6, kicking=7, own_budget=4321))
    raw[18] = 5
    bad = [bytes(raw[:100]), bytes(raw) + b"\0\0", b"RGme\x15" + bytes(raw[5:]), b"RGTD" + bytes(raw[4:])]
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        for b in bad:
            s.sendto(b, ("127.0.0.1", gc_port))
        msg = wait_for(lambda: s.sendto(bytes(raw), ("127.0.0.1", gc_port)) and watcher.latest(), 10, interval=0.2,
                       what="gamestate from a v20 packet")
    assert (msg.version, msg.set_play, msg.kicking_team, msg.stopped, msg.message_budget) == (20, 6, 7, True, 4321)
    assert msg.penalty == msg.PENALTY_MOTION_IN_STOP and msg.penalized_in_place and msg.cautions == 1
    assert msg.secondary_state == msg.STATE_CORNER_KICK and not msg.allowed_to_move
    diag = wait_for(lambda: watcher.gc_diagnostics.get("bad_packets_wrong_header") == "1" and watcher.gc_diagnostics,
                    10, what="bad packets by kind in diagnostics")
    assert (diag["bad_packets_truncated"], diag["bad_packets_over_long"], diag["bad_packets_wrong_version"]) == (
        "1", "1", "1")
    assert diag["gc_version"] == "20" and diag["bad_packets"] == "4"
