"""A simulated GameController: real packets at 2 Hz (HSL v20 by default, v19 or HL v12 on request), a game that
runs by itself, commands by stdin or HTTP.

It runs the Humanoid League flow as the league's GameController does: INITIAL, READY (with its time limit), SET,
PLAYING; a goal sends both teams to READY with the kick-off for the other team; the end of the first half is
FINISHED, then after the half-time break INITIAL of the second half (penalties cleared, the other team kicks off);
the end of the second half is FINISHED. Set plays (throw-in, goal kick, corner kick, free kicks) run as the
GameController of the packets' league runs them: HSL (v19/v20) as its GameController does, play ``stopped`` while
the referee places the ball (neither clock runs), then the kicking team's 45 s on the secondary clock until the ball
is free (the referee's call) or the clock runs out; HL v12 through the three sub-phases of its secondary state. A
robot's return packet asks for a manual penalty or its end
(MAN_PENALISE / MAN_UNPENALISE), acted on as the HL GameController does: only when the robot's message changes,
a penalty only for a robot not penalised, its end only for a penalised one. A v4 status packet (what robots send
an HSL GameController) tells that the robot is there. With ``team_message_address`` it also listens on UDP 10000 +
team number and counts each team's messages against its budget in READY, SET and PLAYING as the HSL GameController
does: a message over 512 bytes or one sent with budget 0 is counted as illegal and logged.

Run: ``python -m robot_nodes.sim.gamecontroller --teams 1 2 --http-port 8038``; in-process:
``with SimulatedGameController(SimulatedGame(teams=(1, 2)), destinations=[("127.0.0.1", port)]) as gc: ...``;
``clock=`` makes it follow another clock (a simulation's time) instead of the wall clock.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

from robot_nodes.runtime.udp import UdpPort
from wire.command_line import CommandParser
from wire.gamecontroller.game_data import HSL_MAX_PAYLOAD, HSL_TEAM_PORT_BASE, NO_TEAM
from wire.gamecontroller.packets import (
    DATA_PORT,
    HL_VERSION,
    HSL_NAMES,
    HSL_VERSION,
    MAX_NUM_PLAYERS,
    RETURN_PORT,
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
    build_state_packet,
    hl_to_hsl,
    parse_any_return_packet,
)

log = logging.getLogger("pitchside.gc_simulator")

# the sub-phases of a set play (secondaryStateInfo[1]): robots freeze while the referee places the ball, then
# may position, then freeze while illegally placed robots are removed; then play goes on (NORMAL)
PLACE_BALL, POSITIONING, REMOVE_ILLEGAL = 0, 1, 2
STOPPED_RATE_HZ = 5.0  # the HSL GameController while play is stopped
BALL_FREE_S = 10  # after a kick-off, the secondary clock counts the seconds until the ball is free (as the HL GC)


class CommandError(ValueError):
    """A penalize/goal/state command the simulated GC cannot carry out; the message says why."""


@dataclass
class SimulatedGame:
    """What game the simulated GC runs and how fast its phases pass (seconds of the GC's clock)."""

    teams: tuple[int, int] = (1, 2)
    team_colors: tuple[int, int] = (0, 1)
    players_per_team: int = 4
    game_type: int = 0
    initial_s: float = 2.0  # 0 or less: stay in INITIAL until told
    ready_s: float = 5.0  # the HL rules give 45 s
    set_s: float = 2.0
    half_s: int = 600
    half_time_s: float = 5.0  # the break between FINISHED of the first half and INITIAL of the second
    # HSL (v19/v20): play stopped while the referee places the ball, then the kicking team's time on the secondary
    # clock (the HSL GameController's setPlays durations of every 2026 competition: 45 s, a penalty kick 60 s)
    set_play_stopped_s: float = 5.0
    set_play_s: float = 45.0
    penalty_kick_s: float = 60.0
    # HL v12: the three sub-phases of a set piece
    set_play_place_s: float = 2.0  # sub-phase 0: the referee places the ball
    set_play_position_s: float = 15.0  # sub-phase 1: robots may position
    set_play_freeze_s: float = 1.0  # sub-phase 2: illegally placed robots are removed
    auto_progress: bool = True
    # the first INITIAL also waits until players 1..n of each team have sent a return packet, as a referee waits
    # for both teams (a simulated match: robots whose nodes still start up would walk behind a lagging world),
    # at most wait_for_players_s
    wait_for_players: tuple[int, int] = (0, 0)
    wait_for_players_s: float = 120.0
    version: int = HSL_VERSION  # of the packets: 20 or 19 (Humanoid Soccer League) or 12 (Humanoid League)
    message_budget: int = 12_000  # team messages per team and game (HSL 2026)
    competition_type: int = 0  # HSL: 0 small, 1 middle, 2 large


@dataclass
class _Slot:
    penalty: int = Penalty.NONE  # HL v12 code
    hsl_penalty: int | None = None  # the HSL v20 code where the HL one does not tell the call (leaving the field)
    secs: float = 0.0
    yellow_cards: int = 0
    red_cards: int = 0
    goalkeeper: bool = False


@dataclass
class _Team:
    number: int
    color: int
    score: int = 0
    slots: list[_Slot] = field(default_factory=list)
    message_budget: int = 0
    team_messages: int = 0  # heard on 10000 + team number, counted or not
    illegal_messages: int = 0  # over 512 bytes, or sent with budget 0


@dataclass(frozen=True, slots=True)
class ReceivedReturn:
    time: float  # monotonic
    address: tuple[str, int]
    packet: ReturnPacket | StatusPacket


class SimulatedGameController:
    """Sends the game's state to each destination every 0.5 s and listens for return packets."""

    def __init__(
        self,
        game: SimulatedGame | None = None,
        destinations: list[tuple[str, int]] | None = None,
        return_address: tuple[str, int] = ("127.0.0.1", RETURN_PORT),
        rate_hz: float = 2.0,
        clock: Callable[[], float] = time.monotonic,
        team_message_address: str | None = None,
        team_message_ports: dict[int, int] | None = None,
    ) -> None:
        self.game = game or SimulatedGame()
        if len(set(self.game.teams)) != 2:
            raise CommandError(f"a game needs two different team numbers, got {self.game.teams}")
        if self.game.version not in (HL_VERSION, *HSL_NAMES):
            raise CommandError(f"protocol version {self.game.version} is not one of 20, 19, 12")
        if not 1 <= self.game.players_per_team <= MAX_NUM_PLAYERS:
            raise CommandError(f"players per team must be 1..{MAX_NUM_PLAYERS}")
        self.destinations = list(destinations or [("127.0.0.1", DATA_PORT)])
        self.rate_hz = rate_hz
        self._clock = clock
        self._lock = threading.Lock()
        self._teams = [
            _Team(number, color, slots=[
                _Slot(penalty=Penalty.NONE if i < self.game.players_per_team else Penalty.SUBSTITUTE,
                      goalkeeper=i == 0)
                for i in range(MAX_NUM_PLAYERS)
            ], message_budget=self.game.message_budget)
            for number, color in zip(self.game.teams, self.game.team_colors, strict=True)
        ]
        self.state = GameStateValue.INITIAL
        self.first_half = True
        self.kick_off_team = self.game.teams[0]
        self.secs_remaining = float(self.game.half_s)
        self.secondary_state = SecondaryState.NORMAL
        self.set_play_team = 0
        self.set_play_phase = PLACE_BALL
        self.packet_number = 0
        self.packets_sent = 0
        self.returns: list[ReceivedReturn] = []
        self.bad_returns = 0
        self._last_message: dict[tuple[int, int], int] = {}  # (team, player) -> last return message
        self._heard: set[tuple[int, int]] = set()  # (team, player) of every return or status packet
        self._phase_started = clock()  # of the game state
        self._set_play_started = clock()  # of the set play's sub-phase
        self._players_heard = False  # the players the first INITIAL waits for are heard (or waited for long enough)
        self._kicked_off_at: float | None = None  # PLAYING after a kick-off: when (the ball is free 10 s later)
        self._last_tick = clock()
        self._stop = threading.Event()
        self._wake = threading.Event()  # a command changed the game: the next packet goes now (HSL)
        self._stopped = False  # play stopped in the last packet
        self._threads: list[threading.Thread] = []
        self._udp = UdpPort(return_address[0], return_address[1], self._on_return, recv_size=2048,
                            name="gc-sim-returns")
        self._http: ThreadingHTTPServer | None = None
        self._team_ports: list[UdpPort] = []
        try:
            for team in (self._teams if team_message_address is not None else []):
                assert team_message_address is not None
                self._team_ports.append(UdpPort(
                    team_message_address, (team_message_ports or {}).get(team.number, HSL_TEAM_PORT_BASE + team.number),
                    self._team_message_handler(team),
                    recv_size=65535, name=f"gc-sim-team-{team.number}", reuse_address=True))
        except OSError:
            self.stop()
            raise

    # -- running ---------------------------------------------------------------------------------------------
    @property
    def return_port(self) -> int:
        """Where robots' return packets arrive (the bound port, also when 0 was asked for)."""
        return self._udp.port

    def start(self) -> SimulatedGameController:
        self._phase_started = self._last_tick = self._clock()
        sender = threading.Thread(target=self._send_loop, name="gc-sim-send", daemon=True)
        sender.start()
        self._threads.append(sender)
        return self

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()
        if self._http is not None:
            self._http.shutdown()
            self._http.server_close()
        for t in self._threads:
            t.join(2.0)
        self._udp.close()
        for port in self._team_ports:
            port.close()

    def __enter__(self) -> SimulatedGameController:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _send_loop(self) -> None:
        """Every 1 / rate_hz; as the HSL GameController also at once after a command and at 5 Hz while play is
        stopped (v19/v20)."""
        next_due = time.monotonic()
        while not self._stop.is_set():
            packet = self.tick()
            for dest in self.destinations:
                try:
                    self._udp.sendto(packet, dest)
                except OSError as exc:  # a robot that is not there yet must not stop the game
                    log.debug("cannot send to %s: %s", dest, exc)
            hsl = self.game.version != HL_VERSION
            period = 1.0 / max(self.rate_hz, STOPPED_RATE_HZ) if hsl and self._stopped else 1.0 / self.rate_hz
            next_due = max(next_due + period, time.monotonic() - period)  # no burst to catch up after a stall
            if self._wait_until(next_due, at_once=hsl):
                next_due = time.monotonic()  # sent at once; the period counts from here

    def _wait_until(self, due: float, at_once: bool) -> bool:
        """Waits for the next packet's time; True if a command cut it short (``at_once``: the HSL GameController
        sends a change at once, the HL one at its next packet)."""
        while not self._stop.is_set():
            left = due - time.monotonic()
            if left <= 0:
                return False
            if self._wake.wait(left):
                self._wake.clear()
                if at_once and not self._stop.is_set():
                    return True
        return False

    def team_message_port(self, team: int) -> int:
        """Where this GameController counts ``team``'s messages (0 if it does not listen)."""
        for t, port in zip(self._teams, self._team_ports, strict=False):
            if t.number == team:
                return port.port
        return 0

    def _team_message_handler(self, team: _Team) -> Callable[[bytes, tuple[str, int]], None]:
        return lambda data, addr: self._on_team_message(team, data, addr)

    def _on_team_message(self, team: _Team, data: bytes, addr: tuple[str, int]) -> None:
        """Counted as the HSL GameController counts: in READY, SET and PLAYING, not in a penalty shoot-out."""
        with self._lock:
            team.team_messages += 1
            counted = (self.state in (GameStateValue.READY, GameStateValue.SET, GameStateValue.PLAYING)
                       and self.secondary_state != SecondaryState.PENALTYSHOOT)
            if not counted:
                return
            if len(data) > HSL_MAX_PAYLOAD or team.message_budget <= 0:
                team.illegal_messages += 1
                log.warning("illegal team message from %s for team %d: %d bytes, budget %d", addr[0], team.number,
                            len(data), team.message_budget)
                return
            team.message_budget -= 1

    def _on_return(self, data: bytes, addr: tuple[str, int]) -> None:
        try:
            packet = parse_any_return_packet(data)
        except GameControllerPacketError as exc:
            self.bad_returns += 1
            log.info("bad return packet from %s: %s", addr, exc)
            return
        with self._lock:
            self.returns.append(ReceivedReturn(time.monotonic(), addr, packet))
            del self.returns[:-10000]
            self._heard.add((packet.team, packet.player))
            if isinstance(packet, StatusPacket):
                return  # a robot's status: it is there; it asks for nothing
            key = (packet.team, packet.player)
            changed = self._last_message.get(key) != packet.message
            self._last_message[key] = packet.message
            if not changed:  # the HL GC acts on a robot's message when it changes, not on every packet
                return
            try:
                slot = self._slot(packet.team, packet.player)
                if packet.message == ReturnMessage.MAN_PENALISE and slot.penalty == Penalty.NONE:
                    self._penalize(packet.team, packet.player, Penalty.MANUAL, 0)
                    log.info("team %d player %d penalised itself (manual penalty)", packet.team, packet.player)
                elif packet.message == ReturnMessage.MAN_UNPENALISE and slot.penalty not in (Penalty.NONE,
                                                                                           Penalty.SUBSTITUTE):
                    self._unpenalize(packet.team, packet.player)
                    log.info("team %d player %d ended its penalty (manual)", packet.team, packet.player)
            except CommandError as exc:
                log.info("ignored return packet from %s: %s", addr, exc)

    # -- the game --------------------------------------------------------------------------------------------
    def tick(self) -> bytes:
        """Advances the clocks to now and returns the next packet (the send loop calls it every 0.5 s)."""
        with self._lock:
            data = self._advance_to_now()
            self._stopped = data.stopped
            self.packet_number = (self.packet_number + 1) % 256
            self.packets_sent += 1
        if self.game.version != HL_VERSION:
            data = self._as_hsl(data)
        return build_state_packet(data)

    def _as_hsl(self, data: GameControlData) -> GameControlData:
        """The game as the HSL GameController tells it: no kicking team once the ball is free (after a kick-off's
        10 s or a set play), and the calls the HL codes cannot tell apart (leaving the field, incapable, pick-up)."""
        data = hl_to_hsl(data, self.game.version)
        if (data.state == GameStateValue.PLAYING and data.set_play == SetPlay.NONE and data.secondary_time == 0
                and data.game_phase == GamePhase.NORMAL):
            data = dataclasses.replace(data, kicking_team=NO_TEAM)
        with self._lock:
            calls = {(t.number, i): slot.hsl_penalty for t in self._teams for i, slot in enumerate(t.slots)
                     if slot.hsl_penalty is not None and slot.penalty != Penalty.NONE}
        if not calls:
            return data
        codes = {} if self.game.version == HSL_VERSION else {
            int(c): int(HslPenaltyV19[c.name]) for c in HslPenalty if c.name in HslPenaltyV19.__members__}

        def team(t: TeamInfo) -> TeamInfo:
            players = tuple(dataclasses.replace(p, penalty=codes.get(calls[t.team_number, i], calls[t.team_number, i]))
                            if (t.team_number, i) in calls else p for i, p in enumerate(t.players))
            return dataclasses.replace(t, players=players)

        return dataclasses.replace(data, teams=(team(data.teams[0]), team(data.teams[1])))

    def snapshot(self) -> GameControlData:
        """The game as the next packet will tell it, clocks advanced to now (for a referee in the same process)."""
        with self._lock:
            return self._advance_to_now()

    def _advance_to_now(self) -> GameControlData:
        now = self._clock()
        dt = max(0.0, now - self._last_tick)
        self._last_tick = now
        self._advance(now, dt)
        return self._snapshot(now)

    def _advance(self, now: float, dt: float) -> None:
        g = self.game
        in_phase = now - self._phase_started
        if self.state not in (GameStateValue.INITIAL, GameStateValue.FINISHED):
            for team in self._teams:
                for slot in team.slots:
                    if slot.penalty not in (Penalty.NONE, Penalty.SUBSTITUTE, Penalty.MANUAL) and slot.secs > 0:
                        slot.secs = max(0.0, slot.secs - dt)
                        if slot.secs == 0:
                            slot.penalty, slot.hsl_penalty = Penalty.NONE, None
        if self.state == GameStateValue.PLAYING:
            if not self._play_stopped():  # the HSL GameController's clock stands while play is stopped
                self.secs_remaining = max(0.0, self.secs_remaining - dt)
            if self.secs_remaining == 0:
                self._finish_half()
                return
            if g.auto_progress and self.secondary_state in SET_PIECES:
                self._advance_set_play(now)
            return
        if not g.auto_progress:
            return
        if (self.state == GameStateValue.INITIAL and g.initial_s > 0 and in_phase >= g.initial_s
                and self._players_ready(now, in_phase)):
            self._enter(GameStateValue.READY)
        elif self.state == GameStateValue.READY and in_phase >= g.ready_s:
            self._enter(GameStateValue.SET)
        elif self.state == GameStateValue.SET and in_phase >= g.set_s:
            self._enter(GameStateValue.PLAYING)
        elif self.state == GameStateValue.FINISHED and self.first_half and in_phase >= g.half_time_s:
            self._enter(GameStateValue.INITIAL)

    def _players_ready(self, now: float, waited: float) -> bool:
        """Before the first kick-off: once every awaited player has been heard, INITIAL lasts initial_s more (their
        robots stand up); after wait_for_players_s the game starts without the missing ones (said once)."""
        if not self.first_half or self._players_heard:
            return True
        missing = [(team.number, player) for team, count in zip(self._teams, self.game.wait_for_players, strict=True)
                   for player in range(1, count + 1) if (team.number, player) not in self._heard]
        if missing and waited < self.game.wait_for_players_s:
            return False
        self._players_heard = True
        if missing:
            log.warning("starting without return packets from %s (waited %.0f s)",
                        ", ".join(f"team {t} player {p}" for t, p in missing), waited)
            return True
        if any(self.game.wait_for_players):
            log.info("every player heard after %.1f s: READY in %.0f s", waited, self.game.initial_s)
            self._phase_started = now
            return False
        return True

    @property
    def hsl(self) -> bool:
        """The game runs as the HSL GameController runs it (v19/v20 packets), not as the HL one (v12)."""
        return self.game.version != HL_VERSION

    def _play_stopped(self) -> bool:
        """HSL: play is stopped while the referee places the ball for a set play (``stopped`` in the packet)."""
        return self.hsl and self.secondary_state in SET_PIECES and self.set_play_phase == PLACE_BALL

    def _set_play_phase_s(self) -> float:
        """How long the running set play's current phase lasts."""
        g = self.game
        if self.hsl:
            return g.set_play_stopped_s if self.set_play_phase == PLACE_BALL else self._kicking_time_s()
        return {PLACE_BALL: g.set_play_place_s, POSITIONING: g.set_play_position_s,
                REMOVE_ILLEGAL: g.set_play_freeze_s}[self.set_play_phase]

    def _kicking_time_s(self) -> float:
        """HSL: the kicking team's time for the running set play (the secondary clock)."""
        penalty_kick = self.secondary_state == SecondaryState.PENALTYKICK
        return self.game.penalty_kick_s if penalty_kick else self.game.set_play_s

    def _advance_set_play(self, now: float) -> None:
        if now - self._set_play_started >= self._set_play_phase_s():
            self._next_set_play_phase()

    def _next_set_play_phase(self) -> None:
        """HSL: stopped -> the kicking team's time -> over; HL: place ball -> positioning -> freeze -> over."""
        if self.set_play_phase == (POSITIONING if self.hsl else REMOVE_ILLEGAL):
            self._end_set_play()
        else:
            self.set_play_phase += 1
        self._set_play_started = self._clock()

    def _end_set_play(self) -> None:
        self.secondary_state, self.set_play_team, self.set_play_phase = SecondaryState.NORMAL, 0, PLACE_BALL

    def _finish_half(self) -> None:
        """The half's clock ran out: FINISHED (after the first half, the half-time break follows)."""
        self._enter(GameStateValue.FINISHED)

    def _enter(self, state: GameStateValue) -> None:
        if state == GameStateValue.INITIAL and self.state == GameStateValue.FINISHED and self.first_half:
            self._switch_half()
        if state != GameStateValue.PLAYING or self.secondary_state not in SET_PIECES:
            self._end_set_play()
        self._kicked_off_at = self._clock() if (state == GameStateValue.PLAYING
                                                and self.state == GameStateValue.SET) else None
        self.state = state
        self._phase_started = self._clock()

    def _switch_half(self) -> None:
        """Half time: the second half's clock, the kick-off for the team that did not kick off the first half,
        every penalty but substitutes cleared (as the HL GC does)."""
        self.first_half = False
        self.secs_remaining = float(self.game.half_s)
        self.kick_off_team = self.game.teams[1]
        for team in self._teams:
            for slot in team.slots:
                if slot.penalty != Penalty.SUBSTITUTE:
                    slot.penalty, slot.secs = Penalty.NONE, 0.0

    def _secondary_time(self, now: float) -> int:
        g = self.game
        if self.state == GameStateValue.PLAYING:
            if self.secondary_state in SET_PIECES:
                if self._play_stopped():  # HSL: the kicking team's clock waits for play to resume
                    return round(self._kicking_time_s())
                return max(0, round(self._set_play_phase_s() - (now - self._set_play_started)))
            if self._kicked_off_at is not None:
                return max(0, round(BALL_FREE_S - (now - self._kicked_off_at)))
            return 0
        lasts: dict[int, float] = {GameStateValue.READY: g.ready_s, GameStateValue.SET: g.set_s}
        if self.first_half:
            lasts[GameStateValue.FINISHED] = g.half_time_s
        left = lasts.get(self.state)
        return 0 if left is None else max(0, round(left - (now - self._phase_started)))

    def _snapshot(self, now: float) -> GameControlData:
        teams = tuple(
            TeamInfo(
                team_number=t.number, team_color=t.color, score=t.score, message_budget=t.message_budget,
                players=tuple(RobotInfo(penalty=s.penalty, secs_till_unpenalized=min(255, round(s.secs)),
                                        yellow_cards=s.yellow_cards, red_cards=s.red_cards,
                                        goalkeeper=s.goalkeeper) for s in t.slots),
            )
            for t in self._teams
        )
        return GameControlData(
            packet_number=self.packet_number,
            players_per_team=self.game.players_per_team,
            game_type=self.game.game_type,
            state=self.state,
            first_half=self.first_half,
            kick_off_team=self.kick_off_team,
            secondary_state=self.secondary_state,
            secondary_state_info=(self.set_play_team, self.set_play_phase if self.set_play_team else 0, 0, 0),
            secs_remaining=round(self.secs_remaining),
            secondary_time=self._secondary_time(now),
            teams=(teams[0], teams[1]),
            competition_type=self.game.competition_type,
        )

    def _team(self, number: int) -> _Team:
        for t in self._teams:
            if t.number == number:
                return t
        raise CommandError(f"team {number} does not play in this game (teams {self.game.teams})")

    def _slot(self, team: int, player: int) -> _Slot:
        if not 1 <= player <= MAX_NUM_PLAYERS:
            raise CommandError(f"player number must be 1..{MAX_NUM_PLAYERS}, got {player}")
        return self._team(team).slots[player - 1]

    def _penalize(self, team: int, player: int, penalty: int, seconds: float, hsl_penalty: int | None = None) -> None:
        slot = self._slot(team, player)
        slot.penalty, slot.secs, slot.hsl_penalty = int(penalty), float(seconds), hsl_penalty

    def _unpenalize(self, team: int, player: int) -> None:
        slot = self._slot(team, player)
        slot.penalty, slot.secs, slot.hsl_penalty = Penalty.NONE, 0.0, None

    # -- commands (any thread) -------------------------------------------------------------------------------
    def penalize(self, team: int, player: int, seconds: float = 30.0,
                 penalty: int = Penalty.PICKUP_OR_INCAPABLE, hsl_penalty: int | None = None) -> None:
        """Seconds > 0: the robot comes back by itself after that time; 0: until unpenalize(). ``penalty`` is the
        HL v12 code; ``hsl_penalty`` the HSL v20 call an HSL packet tells instead (the HL codes have one for
        pick-up and incapable robots together, none for leaving the field)."""
        if not 0 <= seconds <= 255:
            raise CommandError(f"penalty seconds must be 0..255, got {seconds}")
        if not 0 < int(penalty) <= 255:
            raise CommandError(f"penalty code must be 1..255, got {penalty}")
        if hsl_penalty is not None and hsl_penalty not in HslPenalty._value2member_map_:
            raise CommandError(f"unknown HSL penalty code {hsl_penalty}")
        with self._lock:
            self._penalize(team, player, penalty, seconds, hsl_penalty)
        self._wake.set()

    def unpenalize(self, team: int, player: int) -> None:
        with self._lock:
            self._unpenalize(team, player)
        self._wake.set()

    def goal(self, team: int) -> None:
        """Counts a goal (only in PLAYING, as the HL GC); both teams go to READY, the other team kicks off."""
        with self._lock:
            scorer = self._team(team)
            self._advance_to_now()
            if self.state != GameStateValue.PLAYING:
                raise CommandError(f"a goal counts only in PLAYING, the game is in {GameStateValue(self.state).name}")
            scorer.score += 1
            self.kick_off_team = next(n for n in self.game.teams if n != team)
            self._enter(GameStateValue.READY)
        self._wake.set()

    def set_state(self, state: int | str) -> None:
        try:
            value = GameStateValue[state.upper()] if isinstance(state, str) else GameStateValue(state)
        except (KeyError, ValueError):
            raise CommandError(f"unknown game state {state!r}; one of {[s.name for s in GameStateValue]}") from None
        with self._lock:
            self._advance_to_now()
            self._enter(value)
        self._wake.set()

    def set_play(self, kind: int | str, team: int) -> None:
        """Starts a set play for ``team`` (throw-in, goal kick, corner kick, direct/indirect free kick, penalty
        kick), or, for the set play already running, moves it to its next phase (the GC's button pressed again;
        HSL: play resumes, then the ball is free). Only in PLAYING, as the GameController."""
        try:
            value = SecondaryState[kind.upper()] if isinstance(kind, str) else SecondaryState(kind)
        except (KeyError, ValueError):
            value = None
        if value not in SET_PIECES:
            names = [SecondaryState(v).name for v in sorted(SET_PIECES)]
            raise CommandError(f"unknown set play {kind!r}; one of {names}")
        assert value is not None
        with self._lock:
            self._team(team)
            self._advance_to_now()
            if self.state != GameStateValue.PLAYING:
                raise CommandError(f"a set play starts only in PLAYING, the game is in "
                                   f"{GameStateValue(self.state).name}")
            if self.secondary_state == SecondaryState.NORMAL:
                self.secondary_state, self.set_play_team, self.set_play_phase = value, team, PLACE_BALL
                self._set_play_started = self._clock()
                self._kicked_off_at = None
            elif self.secondary_state == value and self.set_play_team == team:
                self._next_set_play_phase()
            else:
                raise CommandError(f"{SecondaryState(self.secondary_state).name} for team {self.set_play_team} "
                                   "is running")
        self._wake.set()

    def ball_free(self) -> None:
        """HSL: the referee's "ball free": the running set play ends once its ball is in play (the HSL
        GameController's FinishSetPlay), only while play runs (not while the ball is placed)."""
        with self._lock:
            self._advance_to_now()
            if not self.hsl:
                raise CommandError("the HL GameController (v12) ends a set piece by its sub-phases, not ball free")
            if self.state != GameStateValue.PLAYING or self.secondary_state not in SET_PIECES:
                raise CommandError("ball free needs a running set play")
            if self._play_stopped():
                raise CommandError("play is stopped: the ball is being placed")
            self._end_set_play()
        self._wake.set()

    def returns_from(self, team: int, player: int) -> list[ReceivedReturn]:
        with self._lock:
            return [r for r in self.returns if r.packet.team == team and r.packet.player == player]

    def status(self) -> dict[str, Any]:
        with self._lock:
            data = self._snapshot(time.monotonic())
            returns = list(self.returns[-20:])
            messages = {t.number: (t.team_messages, t.illegal_messages) for t in self._teams}
        return {
            "version": self.game.version,
            "state": GameStateValue(data.state).name,
            "first_half": data.first_half,
            "kick_off_team": data.kick_off_team,
            "secs_remaining": data.secs_remaining,
            "secondary_time": data.secondary_time,
            "secondary_state": SecondaryState(data.secondary_state).name,
            "set_play_team": data.secondary_state_info[0],
            "set_play_phase": data.secondary_state_info[1],
            "packets_sent": self.packets_sent,
            "destinations": [f"{h}:{p}" for h, p in self.destinations],
            "return_port": self.return_port,
            "teams": [
                {
                    "team": t.team_number,
                    "color": t.team_color,
                    "score": t.score,
                    "message_budget": t.message_budget,
                    "team_messages": messages[t.team_number][0],
                    "illegal_messages": messages[t.team_number][1],
                    "players": [dataclasses.asdict(p) | {"number": i + 1} for i, p in enumerate(t.players)],
                }
                for t in data.teams
            ],
            "returns": [_return_status(r) for r in returns],
            "return_count": len(self.returns),
            "bad_returns": self.bad_returns,
        }

    def execute(self, line: str) -> str:
        """One text command (stdin): penalize T P [S] | unpenalize T P | goal T | state NAME | setplay KIND T |
        ballfree | status."""
        words = line.split()
        if not words:
            return ""
        cmd, args = words[0].lower(), words[1:]
        try:
            if cmd == "penalize" and len(args) in (2, 3):
                self.penalize(int(args[0]), int(args[1]), float(args[2]) if len(args) == 3 else 30.0)
            elif cmd == "unpenalize" and len(args) == 2:
                self.unpenalize(int(args[0]), int(args[1]))
            elif cmd == "goal" and len(args) == 1:
                self.goal(int(args[0]))
            elif cmd == "state" and len(args) == 1:
                self.set_state(args[0])
            elif cmd == "setplay" and len(args) == 2:
                self.set_play(args[0], int(args[1]))
            elif cmd == "ballfree" and not args:
                self.ball_free()
            elif cmd == "status":
                return json.dumps(self.status(), indent=1)
            else:
                return ("commands: penalize TEAM PLAYER [SECONDS] | unpenalize TEAM PLAYER | goal TEAM | "
                        "state NAME | setplay KIND TEAM (throw_in, goal_kick, corner_kick, ...) | ballfree | status")
        except (CommandError, ValueError) as exc:
            return f"error: {exc}"
        return "ok"

    # -- HTTP API --------------------------------------------------------------------------------------------
    def serve_http(self, port: int, host: str = "127.0.0.1") -> int:
        """Starts the HTTP API on a thread; returns the bound port."""
        self._http = ThreadingHTTPServer((host, port), _make_handler(self))
        t = threading.Thread(target=self._http.serve_forever, name="gc-sim-http", daemon=True)
        t.start()
        self._threads.append(t)
        return int(self._http.server_address[1])


def _return_status(r: ReceivedReturn) -> dict[str, Any]:
    out: dict[str, Any] = {"age_s": round(time.monotonic() - r.time, 3), "address": f"{r.address[0]}:{r.address[1]}",
                           "team": r.packet.team, "player": r.packet.player}
    if isinstance(r.packet, StatusPacket):
        return out | {"message": "STATUS", "fallen": r.packet.fallen, "pose_mm": list(r.packet.pose_mm),
                      "ball_age_s": r.packet.ball_age_s, "ball_mm": list(r.packet.ball_mm)}
    message = r.packet.message
    return out | {"message": ReturnMessage(message).name if message in ReturnMessage._value2member_map_ else message}


def _make_handler(gc: SimulatedGameController) -> type[BaseHTTPRequestHandler]:
    class Handler(BaseHTTPRequestHandler):
        """POST /penalize {team, player, seconds}, /unpenalize, /goal {team}, /state {state}, /set-play {kind,
        team}, /ball-free; GET /status."""

        def log_message(self, fmt: str, *args: Any) -> None:
            log.debug(fmt, *args)

        def _reply(self, code: int, body: dict[str, Any]) -> None:
            payload = json.dumps(body).encode()
            self.send_response(code)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(payload)))
            self.end_headers()
            self.wfile.write(payload)

        def do_GET(self) -> None:
            if self.path.rstrip("/") == "/status":
                self._reply(200, gc.status())
            else:
                self._reply(404, {"error": f"no such endpoint GET {self.path}"})

        def do_POST(self) -> None:
            try:
                length = int(self.headers.get("Content-Length") or 0)
                body = json.loads(self.rfile.read(length) or b"{}")
                if not isinstance(body, dict):
                    raise CommandError("the body must be a JSON object")
                path = self.path.rstrip("/")
                if path == "/penalize":
                    gc.penalize(int(body["team"]), int(body["player"]), float(body.get("seconds", 30)),
                                int(body.get("penalty", Penalty.PICKUP_OR_INCAPABLE)))
                elif path == "/unpenalize":
                    gc.unpenalize(int(body["team"]), int(body["player"]))
                elif path == "/goal":
                    gc.goal(int(body["team"]))
                elif path == "/state":
                    gc.set_state(body["state"])
                elif path == "/set-play":
                    gc.set_play(body["kind"], int(body["team"]))
                elif path == "/ball-free":
                    gc.ball_free()
                else:
                    self._reply(404, {"error": f"no such endpoint POST {self.path}"})
                    return
            except KeyError as exc:
                self._reply(400, {"error": f"missing field {exc}"})
                return
            except (CommandError, ValueError, TypeError) as exc:
                self._reply(400, {"error": str(exc)})
                return
            self._reply(200, {"ok": True, "status": gc.status()})

    return Handler


def _address(text: str, default_port: int) -> tuple[str, int]:
    host, _, port = text.rpartition(":")
    return (host, int(port)) if host else (text, default_port)


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(description="Simulated RoboCup GameController (HSL v20 packets by default)")
    parser.add_argument("--teams", type=int, nargs=2, default=[1, 2], metavar=("HOME", "AWAY"))
    parser.add_argument("--players-per-team", type=int, default=4)
    parser.add_argument("--to", action="append", default=None, metavar="HOST[:PORT]",
                        help=f"destination (repeatable; default 127.0.0.1:{DATA_PORT}; a broadcast address works too)")
    parser.add_argument("--port", type=int, default=DATA_PORT, help="port for destinations given without one")
    parser.add_argument("--return-address", default=f"0.0.0.0:{RETURN_PORT}", help="where return packets arrive")
    parser.add_argument("--http-port", type=int, default=None, help="serve the HTTP API on this port (127.0.0.1)")
    parser.add_argument("--initial", type=float, default=2.0, help="seconds in INITIAL (0: wait for a command)")
    parser.add_argument("--ready", type=float, default=5.0)
    parser.add_argument("--set", dest="set_s", type=float, default=2.0)
    parser.add_argument("--half", type=int, default=600, help="seconds per half")
    parser.add_argument("--half-time", type=float, default=5.0, help="seconds of the half-time break")
    parser.add_argument("--manual", action="store_true", help="do not progress the states by time")
    parser.add_argument("--protocol", type=int, choices=[HSL_VERSION, 19, HL_VERSION], default=HSL_VERSION,
                        help="packet version: 20 (HSL 2026, default), 19 (HSL, March 2026) or 12 (Humanoid League)")
    parser.add_argument("--message-budget", type=int, default=12_000, help="team messages per team and game")
    parser.add_argument("--count-team-messages", action="store_true",
                        help="listen on UDP 10000 + team number and count team messages against the budget")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s [gc-sim] %(message)s")
    game = SimulatedGame(teams=(args.teams[0], args.teams[1]), players_per_team=args.players_per_team,
                         initial_s=args.initial, ready_s=args.ready, set_s=args.set_s, half_s=args.half,
                         half_time_s=args.half_time, auto_progress=not args.manual, version=args.protocol,
                         message_budget=args.message_budget)
    destinations = [_address(d, args.port) for d in (args.to or ["127.0.0.1"])]
    gc = SimulatedGameController(game, destinations, _address(args.return_address, RETURN_PORT),
                                 team_message_address="0.0.0.0" if args.count_team_messages else None)
    gc.start()
    if args.http_port is not None:
        log.info("HTTP API on http://127.0.0.1:%d", gc.serve_http(args.http_port))
    log.info("sending to %s, return packets on port %d; type 'help' for commands",
             ", ".join(f"{h}:{p}" for h, p in destinations), gc.return_port)
    try:
        for line in sys.stdin:
            reply = gc.execute(line)
            if reply:
                print(reply, flush=True)
        while True:  # stdin closed (e.g. started in the background): keep the game going
            time.sleep(3600)
    except KeyboardInterrupt:
        pass
    finally:
        gc.stop()


if __name__ == "__main__":
    main()
