"""A team on one machine and the GameController: every robot hears the broadcasts (the game_controller node binds
with address reuse), and a robot's manual penalty reaches the GameController in its return packets."""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator
from typing import Any

import pytest

import schemas
from robot_nodes.game_controller.receiver import GameControllerNode
from robot_nodes.hcm.pause import PauseNode
from robot_nodes.runtime import BusConfig, Node, open_session
from robot_nodes.sim.gamecontroller import SimulatedGame, SimulatedGameController
from tests.support import free_port
from tests.waiting import wait_for
from wire.gamecontroller.packets import Penalty, ReturnMessage
from wire.services import call_service

LOOPBACK_BROADCAST = "127.255.255.255"


class Watcher(Node):
    """What a robot's other nodes hear: its gamestate and paused topics."""

    name = "watcher"

    def setup(self) -> None:
        self.lock = threading.Lock()
        self.gamestate: Any = None
        self.paused: bool | None = None
        self.subscribe("gamestate", self._on_gamestate)
        self.subscribe("paused", self._on_paused)

    def _on_gamestate(self, msg: Any) -> None:
        with self.lock:
            self.gamestate = msg

    def _on_paused(self, msg: Any) -> None:
        with self.lock:
            self.paused = bool(msg.data)


@pytest.fixture
def gc_port() -> int:
    return free_port(socket.SOCK_DGRAM)


def start_robot(bus: BusConfig, robot: str, team: int, player: int, listen: str, port: int,
                return_port: int) -> tuple[GameControllerNode, Watcher]:
    node = GameControllerNode(robot_id=robot, bus=bus, overrides={
        "team_number": team, "player_number": player, "listen_address": listen, "listen_port": port,
        "return_port": return_port})
    node.start()
    watcher = Watcher(robot_id=robot, bus=bus)
    watcher.start()
    return node, watcher


def test_every_robot_on_one_machine_hears_the_broadcasts(bus: BusConfig, gc_port: int) -> None:
    """Two teams of two on one machine, one port: a match's robots bound to the loopback broadcast address (they
    hear nothing from the network), robots as on a real field bound to every interface. A GameController that
    broadcasts reaches all of them; each answers from its own socket."""
    game = SimulatedGame(teams=(3, 8), team_colors=(0, 1), players_per_team=2, initial_s=0.3, ready_s=0.5)
    robots = [("home1", 3, 1, LOOPBACK_BROADCAST), ("home2", 3, 2, "0.0.0.0"),
              ("away1", 8, 1, LOOPBACK_BROADCAST), ("away2", 8, 2, "0.0.0.0")]
    with SimulatedGameController(game, [(LOOPBACK_BROADCAST, gc_port)], ("127.0.0.1", 0), rate_hz=4.0) as gc:
        started = [start_robot(bus, robot, team, player, listen, gc_port, gc.return_port)
                   for robot, team, player, listen in robots]
        try:
            for (robot, _team, _player, _listen), (_node, watcher) in zip(robots, started, strict=True):
                msg = wait_for(lambda w=watcher: w.gamestate is not None and w.gamestate.game_state >= 1
                               and w.gamestate, 15, what=f"{robot} hears READY")
                assert msg.team_color == (0 if robot.startswith("home") else 1)
            for _robot, team, player, _listen in robots:
                wait_for(lambda t=team, p=player: len(gc.returns_from(t, p)) >= 2, 15,
                         what=f"return packets of team {team} player {player}")
            assert all(node.bad_packets == 0 and node.packets >= 2 for node, _ in started)
        finally:
            for node, watcher in started:
                watcher.shutdown()
                node.shutdown()


def test_a_unicast_reaches_only_one_of_them(gc_port: int) -> None:
    """Why a match broadcasts: two sockets on one port with address reuse, a datagram sent to the machine's own
    address is delivered to one of them only."""
    received: list[int] = []
    sockets = []
    for _ in range(2):
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind(("0.0.0.0", gc_port))
        s.settimeout(0.5)
        sockets.append(s)
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
            sender.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
            sender.sendto(b"unicast", ("127.0.0.1", gc_port))
            sender.sendto(b"broadcast", (LOOPBACK_BROADCAST, gc_port))
        for i, s in enumerate(sockets):
            try:
                while True:
                    data, _ = s.recvfrom(64)
                    received.append(i if data == b"unicast" else 10 + i)
            except TimeoutError:
                pass
    finally:
        for s in sockets:
            s.close()
    assert sorted(r for r in received if r >= 10) == [10, 11]  # the broadcast: both
    assert len([r for r in received if r < 10]) == 1  # the unicast: one


@pytest.fixture
def game(gc_port: int) -> Iterator[SimulatedGameController]:
    playing = SimulatedGame(teams=(5, 6), players_per_team=4, initial_s=0, auto_progress=False, version=12)
    with SimulatedGameController(playing, [("127.0.0.1", gc_port)], ("127.0.0.1", 0), rate_hz=4.0) as gc:
        gc.set_state("playing")
        yield gc


def test_a_manual_penalty_goes_to_the_gamecontroller_and_back(bus: BusConfig, game: SimulatedGameController,
                                                              gc_port: int) -> None:
    """The robot's manual_penalize service (its button) -> pause -> manual_penalty -> game_controller ->
    MAN_PENALISE -> the simulated GameController penalises it (MANUAL) -> gamestate says penalised; and back."""
    port = gc_port
    node, watcher = start_robot(bus, "robot2", 5, 2, "127.0.0.1", port, game.return_port)
    pause = PauseNode(robot_id="robot2", bus=bus)
    pause.start()
    session = open_session(bus)
    request = "humanoid_league_msgs/srv/ManualPenalize_Request"
    on_off = schemas.constants(request)

    def slot() -> dict[str, Any]:
        return dict(game.status()["teams"][0]["players"][1])

    def messages_since(count: int) -> list[int]:
        return [r.packet.message for r in game.returns_from(5, 2)[count:]]

    try:
        wait_for(lambda: watcher.gamestate is not None and watcher.gamestate.game_state == 3, 15, what="PLAYING")
        wait_for(lambda: len(game.returns_from(5, 2)) >= 2, 10, what="ALIVE packets")
        assert set(messages_since(0)) == {ReturnMessage.ALIVE} and slot()["penalty"] == Penalty.NONE

        reply = call_service(session, "robot2", "manual_penalize", schemas.make(request, penalize=on_off["ON"]))
        assert reply.penalized
        wait_for(lambda: slot()["penalty"] == Penalty.MANUAL, 10, what="the GC penalises the robot (MANUAL)")
        wait_for(lambda: watcher.gamestate.penalized and watcher.paused, 10, what="gamestate penalised, paused")
        assert watcher.gamestate.seconds_till_unpenalized == 0 and not watcher.gamestate.allowed_to_move
        assert node.return_message() == ReturnMessage.MAN_PENALISE
        sent = len(game.returns_from(5, 2))
        wait_for(lambda: len(messages_since(sent)) >= 3, 10, what="more return packets")
        assert set(messages_since(sent)) == {ReturnMessage.MAN_PENALISE}  # for as long as the penalty lasts

        mark = len(game.returns_from(5, 2))
        reply = call_service(session, "robot2", "manual_penalize", schemas.make(request, penalize=on_off["OFF"]))
        wait_for(lambda: slot()["penalty"] == Penalty.NONE, 10, what="the GC ends the manual penalty")
        wait_for(lambda: not watcher.gamestate.penalized and watcher.paused is False, 10, what="playing again")
        wait_for(lambda: messages_since(mark)[-2:] == [ReturnMessage.ALIVE] * 2, 10, what="ALIVE again")
        told = messages_since(mark)
        assert ReturnMessage.MAN_UNPENALISE in told and told[0] == ReturnMessage.MAN_UNPENALISE
        assert told.count(ReturnMessage.MAN_UNPENALISE) <= 6

        # the button pressed and let go before the GameController's next packet: it penalised the robot on
        # MAN_PENALISE, so the robot must still say MAN_UNPENALISE, though its last gamestate said not penalised
        mark = len(game.returns_from(5, 2))
        for switch in ("ON", "OFF"):
            call_service(session, "robot2", "manual_penalize", schemas.make(request, penalize=on_off[switch]))
        wait_for(lambda: ReturnMessage.MAN_UNPENALISE in messages_since(mark), 10, what="MAN_UNPENALISE")
        wait_for(lambda: messages_since(mark)[-2:] == [ReturnMessage.ALIVE] * 2, 10, what="ALIVE again")
        assert slot()["penalty"] == Penalty.NONE and not watcher.gamestate.penalized

        # a penalty of the referee is not the robot's own: the robot keeps saying ALIVE, its button is not pressed
        mark = len(game.returns_from(5, 2))
        game.penalize(5, 2, seconds=30)
        wait_for(lambda: watcher.gamestate.penalized and watcher.paused, 10, what="penalised by the referee")
        wait_for(lambda: len(messages_since(mark)) >= 3, 10, what="return packets while penalised")
        assert set(messages_since(mark)) == {ReturnMessage.ALIVE}
        assert slot()["penalty"] == Penalty.PICKUP_OR_INCAPABLE
    finally:
        session.close()
        pause.shutdown()
        watcher.shutdown()
        node.shutdown()
