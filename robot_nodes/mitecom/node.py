"""Mixed-team communication node: this robot's state to its teammates over UDP, theirs into `team_data`.

With ``hsl`` it follows the Humanoid Soccer League's rules (2026): one UDP broadcast per message to port 10000 +
team number, received on the same port, at most 512 bytes of payload (a larger message is refused here, with a log
line), and no more messages than the GameController's budget allows, spread over the game time left (module
budget); with budget 0 nothing is sent. The budget is kept whenever the GameController reports one (v19/v20).

It also says what it hears (`team_comm`): each teammate heard lately, the age of its newest message and how many of
its messages went missing, counted against the rate the team sends at (this node's send_rate_hz; team messages
carry no sequence number). The thesis names this as further work: "the wireless connections are very instable
during competition".

Anyone on the field's network can send to a team's port, so with ``team_key`` every message is signed and only
teammates' signed messages are believed (module signing; refusals counted in diagnostics by reason). Unsigned
messages, for a mixed team whose partners do not sign, need ``unsigned``; without either the node hears loopback
only (the lab, a simulation on one machine) and refuses to listen beyond it.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any

import schemas
from robot_nodes.mitecom import codec as mitecom_codec
from robot_nodes.mitecom import protobuf_codec
from robot_nodes.mitecom.budget import BUDGET_UNKNOWN, HSL_MAX_PAYLOAD, BudgetPacer, team_port
from robot_nodes.mitecom.codec import MitecomError, Orientation
from robot_nodes.mitecom.protobuf_codec import TeamMessageError
from robot_nodes.mitecom.report import HCM_PENALTY, NOT_TOLD, SeenRobot, TeammateReport
from robot_nodes.mitecom.signing import REASONS, SignatureError, TeamMessageGuard, TeamMessageSigner
from robot_nodes.runtime import Node, header, param, run
from robot_nodes.runtime.udp import UdpPort
from schemas.codec import Message
from schemas.messages import Position2D, TeamCommStatus, TeamData
from schemas.std import Pose2D
from wire.machine import is_loopback
from wire.telemetry.datagram import DEV_KEY, load_key

_RECV_SIZE = 65535
_ROBOT_MAGENTA, _ROBOT_CYAN = 2, 3  # ObstacleRelative colours
_BLUE = 0  # GameState.BLUE
HSL_FIRST_VERSION = 19  # GameState.version of the first GameController with a message budget


@dataclass
class MitecomParams:
    codec: str = param("mitecom", choices=["mitecom", "protobuf"], doc="wire format of the team messages")
    team_id: int = param(1, range=(0, 65535), doc="team number; Mitecom messages of other teams are ignored")
    player_id: int = param(1, range=(1, 255), doc="this robot's id in the team messages")
    send_rate_hz: float = param(2.0, range=(0.2, 10.0), doc="team messages per second")
    listen_address: str = param("127.0.0.1", doc="address to receive teammates' messages on (loopback in the lab; "
                                                  "0.0.0.0 on a field, with team_key or unsigned)")
    port: int = param(mitecom_codec.DEFAULT_PORT, range=(1, 65535), doc="UDP port this robot listens on")
    peers: str = param("127.0.0.1", doc="comma-separated host[:port] to send to (port defaults to `port`)")
    broadcast: bool = param(False, doc="also send to 255.255.255.255:port (real fields; not needed on loopback)")
    teammate_timeout_s: float = param(2.0, range=(0.2, 60.0), doc="a silent teammate is dropped after this")
    max_data_age_s: float = param(1.0, range=(0.1, 10.0), doc="perception older than this is not sent")
    orientation: str = param("degrees", choices=["degrees", "milliradians"],
                             doc="Mitecom heading unit: the spec's degrees, or milliradians as Bit-Bots sent")
    walking_speed_estimate: float = param(0.15, range=(0.01, 2.0), doc="m/s used to estimate the time to the ball")
    max_kicking_distance: float = param(2.0, range=(0.0, 20.0), doc="m, how far this robot can kick")
    loss_window_s: float = param(10.0, range=(1.0, 120.0), doc="team_comm: loss counted over this many seconds")
    status_memory_s: float = param(30.0, range=(1.0, 600.0),
                                   doc="team_comm: a teammate silent this long is no longer listed")
    hsl: bool = param(False, doc="HSL team communication: broadcast to and listen on UDP 10000 + team_id (port, "
                                 "peers and broadcast are then not used), payloads of at most 512 bytes")
    team_port: int = param(0, range=(0, 65535), doc="with hsl: the UDP port of the team's messages (0: 10000 + "
                                                    "team_id, as on a field; a match on one machine picks free ones)")
    broadcast_address: str = param("255.255.255.255", doc="where HSL team messages go (the field network's "
                                                           "broadcast address)")
    half_s: float = param(600.0, range=(10.0, 3600.0), doc="length of a half: the GameController's message "
                                                           "budget is spread over the game time left")
    budget_reserve: float = param(0.1, range=(0.0, 0.9), doc="share of the message budget kept back for "
                                                             "stoppages and extra time")
    team_key: str = param("", doc="the team key file (team.key of `pitchside team-keys`, or hex): messages are "
                                  "signed with a key derived from it, and only teammates' signed ones believed")
    unsigned: bool = param(False, doc="send and believe unsigned messages (a mixed team whose partners do not "
                                      "sign): anyone who reaches the port can then forge a teammate")
    signature_window_s: float = param(30.0, range=(1.0, 3600.0), doc="a signed message is believed only if sent "
                                                                     "within this of the receiver's clock")


@dataclass
class MateLink:
    """What arrived from one teammate: when first and last, and the arrival times within the loss window."""

    first: float
    newest: float
    arrivals: deque[float] = field(default_factory=deque)

    def heard(self, now: float, window_s: float) -> None:
        self.newest = now
        self.arrivals.append(now)
        self.forget(now, window_s)

    def forget(self, now: float, window_s: float) -> None:
        while self.arrivals and now - self.arrivals[0] > window_s:
            self.arrivals.popleft()

    def loss_pct(self, now: float, window_s: float, rate_hz: float) -> float:
        """Missing messages in percent: expected over the window (or since first heard), received within it."""
        expected = min(window_s, now - self.first) * rate_hz
        if expected < 1.0:
            return 0.0
        return max(0.0, min(100.0, 100.0 * (1.0 - len(self.arrivals) / expected)))


def parse_peers(text: str, default_port: int) -> list[tuple[str, int]]:
    """'a, b:1234' -> [(a, default_port), (b, 1234)]; ValueError names a bad entry."""
    out = []
    for item in (p.strip() for p in text.split(",")):
        if not item:
            continue
        host, sep, port = item.rpartition(":")
        if not sep:
            host, port = item, str(default_port)
        if not host or not port.isdigit() or not 1 <= int(port) <= 65535:
            raise ValueError(f"bad peer {item!r}, expected host or host:port")
        out.append((host, int(port)))
    return out


class MitecomNode(Node):
    """Tells teammates where this robot is, what it sees and plans; collects what they tell (team_data)."""

    name = "mitecom"
    Params = MitecomParams

    def setup(self) -> None:
        self.team_data_pub = self.publisher("team_data")
        self.team_comm_pub = self.publisher("team_comm")
        self.links: dict[int, MateLink] = {}
        self.latest: dict[str, tuple[float, Message]] = {}
        for topic in ("position", "ball_relative", "strategy", "robot_state", "cmd_vel", "walk_odometry",
                      "obstacles_relative", "gamestate", "goal_relative"):
            self.subscribe(topic, lambda msg, t=topic: self._remember(t, msg))
        self.mates: dict[int, tuple[float, TeammateReport]] = {}
        self.sent = 0
        self.received = 0
        self.malformed = 0
        self.other_teams = 0
        self.send_errors = 0
        self.oversized = 0  # messages refused for being over 512 bytes (hsl)
        self.budget = BudgetPacer(half_s=self.params.half_s, reserve=self.params.budget_reserve)
        self._destinations: list[tuple[str, int]] = []
        self._udp: UdpPort | None = None
        self.guard = self._make_guard()
        self._update_destinations()
        self._open_socket()
        self._send_timer = self.timer(self._tick, rate_hz=self.params.send_rate_hz, name="team_messages")

    # -- inputs ---------------------------------------------------------------------------------------------
    def _remember(self, topic: str, msg: Message) -> None:
        self.latest[topic] = (self.now(), msg)

    def _fresh(self, topic: str, max_age: float | None = None) -> Any:  # Any: the topic's own class
        item = self.latest.get(topic)
        if item is None:
            return None
        if max_age is not None and self.now() - item[0] > max_age:
            return None
        return item[1]

    def own_report(self) -> TeammateReport:
        """This robot's message, from the newest data of its topics."""
        age = self.params.max_data_age_s
        position = self._fresh("position", age)
        ball = self._fresh("ball_relative", age)
        strategy = self._fresh("strategy")
        robot_state = self._fresh("robot_state")
        gamestate = self._fresh("gamestate")
        cmd_vel = self._fresh("cmd_vel", age)
        odometry = self._fresh("walk_odometry", age)
        obstacles = self._fresh("obstacles_relative", age)
        goal = self._fresh("goal_relative", age)

        state = robot_state.state if robot_state is not None else None
        if state is None and gamestate is not None and gamestate.penalized:
            state = HCM_PENALTY
        ball_xy = (ball.ball_relative.x, ball.ball_relative.y) if ball is not None else None
        speed = None
        if odometry is not None:
            speed = math.hypot(odometry.twist.twist.linear.x, odometry.twist.twist.linear.y)
        elif cmd_vel is not None:
            speed = math.hypot(cmd_vel.linear.x, cmd_vel.linear.y)
        team_color = gamestate.team_color if gamestate is not None else None
        opponents: list[SeenRobot] = []
        teammates: list[SeenRobot] = []
        if obstacles is not None and team_color is not None:
            own_colour = _ROBOT_CYAN if team_color == _BLUE else _ROBOT_MAGENTA
            for o in obstacles.obstacles:
                if o.color in (_ROBOT_MAGENTA, _ROBOT_CYAN):
                    (teammates if o.color == own_colour else opponents).append(
                        SeenRobot(o.position.x, o.position.y, float(o.confidence)))
        return TeammateReport(
            robot_id=self.params.player_id,
            team_id=self.params.team_id,
            role=strategy.role if strategy is not None else None,
            action=strategy.action if strategy is not None else None,
            state=state,
            offensive_side=strategy.offensive_side if strategy is not None else None,
            position=(position.pose.x, position.pose.y, position.pose.theta) if position is not None else None,
            position_confidence=float(position.confidence) if position is not None else 0.0,
            ball=ball_xy,
            ball_confidence=float(ball.confidence) if ball is not None else 0.0,
            oppgoal=((goal.left_post.x + goal.right_post.x) / 2, (goal.left_post.y + goal.right_post.y) / 2)
            if goal is not None else None,
            oppgoal_confidence=float(goal.confidence) if goal is not None else 0.0,
            opponents=tuple(opponents),
            teammates=tuple(teammates),
            walking_speed=speed,
            walk_command=(cmd_vel.linear.x, cmd_vel.linear.y, cmd_vel.angular.z) if cmd_vel is not None else None,
            time_to_ball=math.hypot(*ball_xy) / self.params.walking_speed_estimate if ball_xy else None,
            max_kicking_distance=self.params.max_kicking_distance,
            team_color=team_color,
        )

    # -- wire -----------------------------------------------------------------------------------------------
    @property
    def _orientation(self) -> Orientation:
        return Orientation.DEGREES if self.params.orientation == "degrees" else Orientation.MILLIRADIANS

    def encode(self, report: TeammateReport) -> bytes:
        if self.params.codec == "protobuf":
            return protobuf_codec.encode(report)
        return mitecom_codec.encode(report, self._orientation)

    def decode(self, data: bytes) -> TeammateReport:
        if self.params.codec == "protobuf":
            return protobuf_codec.decode(data)
        return mitecom_codec.decode(data, self._orientation)

    @property
    def listen_port(self) -> int:
        """The port team messages arrive on: 10000 + team_id with hsl, else ``port``."""
        if not self.params.hsl:
            return self.params.port
        return self.params.team_port or team_port(self.params.team_id)

    def _update_destinations(self) -> None:
        if self.params.hsl:
            self._destinations = [(self.params.broadcast_address, self.listen_port)]
            return
        try:
            destinations = parse_peers(self.params.peers, self.params.port)
        except ValueError as exc:
            self.record_error(f"peers: {exc}")
            destinations = []
        if self.params.broadcast:
            destinations.append(("255.255.255.255", self.params.port))
        self._destinations = destinations

    def _make_guard(self) -> TeamMessageGuard | None:
        """How messages are signed and checked; None when the node may neither listen nor send (why: last_error)."""
        p = self.params
        if p.unsigned:
            guard = TeamMessageGuard(None)
        elif p.team_key:
            try:
                key = load_key(p.team_key)
            except (ValueError, OSError) as exc:
                self.record_error(f"team_key: {exc}; the team communication is off")
                return None
            if key == DEV_KEY:
                self.record_error("team_key is the published development key: it signs nothing a stranger could "
                                  "not; the team communication is off")
                return None
            guard = TeamMessageGuard(TeamMessageSigner(key, p.team_id, min(p.player_id, 255), p.signature_window_s))
        elif is_loopback(p.listen_address):
            guard = TeamMessageGuard(None)  # only this machine reaches the port
        else:
            self.record_error(f"not listening on {p.listen_address}: anyone on the network could forge teammates; "
                              "give team_key=team.key (signed messages), or unsigned=true for a mixed team that "
                              "does not sign; the team communication is off")
            return None
        self.set_diagnostic("team_messages", guard.mode)
        for reason in REASONS:
            self.set_diagnostic(f"refused_{reason}", 0)
        return guard

    def _open_socket(self) -> None:
        if self.guard is None:
            self.set_diagnostic("team_messages", "off")
            return
        self._udp = UdpPort(self.params.listen_address, self.listen_port,
                            lambda data, _addr: self._on_datagram(data), loop=self.loop,
                            recv_size=_RECV_SIZE, name="mitecom-receiver", reuse_address=True)

    def _close_socket(self) -> None:
        if self._udp is not None:
            self._udp.close()
        self._udp = None

    def _tick(self) -> None:
        self._send()
        self._publish_team_data()
        self._publish_team_comm()

    def _budget_allows(self) -> bool:
        """Whether the GameController's message budget lets this tick's message go (always, without a budget)."""
        gs = self._fresh("gamestate")
        if gs is not None:
            # only an HSL GameController (v19 on) keeps a budget; a GameState from elsewhere says version 0
            budget = int(gs.message_budget) if int(gs.version) >= HSL_FIRST_VERSION else BUDGET_UNKNOWN
            self.budget.update(budget, int(gs.players_per_team) or 1, gs.seconds_remaining,
                               bool(gs.first_half), int(gs.game_state), int(gs.game_phase))
        allowed = self.budget.may_send(self.now(), self.params.send_rate_hz)
        left = self.budget.budget_left
        self.set_diagnostic("message_budget", "unknown" if left == BUDGET_UNKNOWN else left)
        rate = self.budget.allowed_rate_hz
        self.set_diagnostic("budget_rate_hz", "unlimited" if rate is None else f"{rate:.3f}")
        self.set_diagnostic("held_back_by_budget", self.budget.held_back)
        return allowed

    def _send(self) -> None:
        if self._udp is None or self.guard is None:
            return
        allowed = self._budget_allows()
        self.set_diagnostic("send_rate_hz", f"{self.budget.send_rate_hz(self.now()):.2f}")
        if not allowed:
            return
        try:
            data = self.encode(self.own_report())
        except (MitecomError, TeamMessageError) as exc:
            if "more than the" in str(exc):
                self.oversized += 1
                self.set_diagnostic("oversized", self.oversized)
            self.record_error(f"cannot encode the team message: {exc}")
            return
        data = self.guard.outgoing(data)  # the signature counts against the HSL's 512 bytes
        if self.params.hsl and len(data) > HSL_MAX_PAYLOAD:
            self.oversized += 1
            self.set_diagnostic("oversized", self.oversized)
            self.record_error(f"team message of {len(data)} bytes not sent: the HSL allows at most "
                              f"{HSL_MAX_PAYLOAD} bytes of payload (the GameController would void the team's goals)")
            return
        for dest in self._destinations:
            try:
                self._udp.sendto(data, dest)
                self.sent += 1
            except OSError as exc:  # a peer that is not up yet, or no route: the next tick tries again
                self.send_errors += 1
                self.set_diagnostic("last_send_error", f"{dest[0]}:{dest[1]}: {exc}")
        self.set_diagnostic("sent", self.sent)

    def _refused(self, reason: str, detail: str) -> None:
        """Counted by reason; logged the first time only (a stranger's flood must not flood the log)."""
        if self.guard is not None:
            count = self.guard.rejected[reason]
            self.set_diagnostic(f"refused_{reason}", count)
            if count == 1:
                self.record_error(f"team message refused ({reason}): {detail}")

    def _on_datagram(self, data: bytes) -> None:
        if self.guard is None:
            return
        try:
            signer, data = self.guard.incoming(data)
        except SignatureError as exc:
            self._refused(exc.reason, str(exc))
            return
        try:
            report = self.decode(data)
        except (MitecomError, TeamMessageError) as exc:
            self.malformed += 1
            self.set_diagnostic("malformed", self.malformed)
            self.record_error(f"malformed team message: {exc}")
            return
        if self.params.codec == "mitecom" and report.team_id != self.params.team_id:
            self.other_teams += 1
            self.set_diagnostic("other_teams", self.other_teams)
            return
        if report.robot_id > 255:
            self.malformed += 1
            self.record_error(f"team message from robot id {report.robot_id}: team_data holds ids up to 255")
            return
        if signer is not None and signer != report.robot_id:
            self.guard.rejected["forged"] += 1  # a teammate's signature on another robot's name
            self._refused("forged", f"signed by {signer}, names robot {report.robot_id}")
            return
        if report.robot_id == self.params.player_id:
            return  # our own message, back through broadcast or a peer list that names us
        is_new = report.robot_id not in self.mates
        now = self.now()
        self.mates[report.robot_id] = (now, report)
        self.links.setdefault(report.robot_id, MateLink(now, now)).heard(now, self.params.loss_window_s)
        self.received += 1
        self.set_diagnostic("received", self.received)
        if is_new:
            self._publish_team_data()

    def _publish_team_data(self) -> None:
        now = self.now()
        timeout = self.params.teammate_timeout_s
        self.mates = {rid: item for rid, item in self.mates.items() if now - item[0] <= timeout}
        self.set_diagnostic("teammates", len(self.mates))
        self.team_data_pub.publish(team_data_message(
            [(now - seen, report) for _rid, (seen, report) in sorted(self.mates.items())]))

    def _publish_team_comm(self) -> None:
        p = self.params
        now = self.now()
        self.links = {rid: link for rid, link in self.links.items() if now - link.newest <= p.status_memory_s}
        ids = sorted(self.links)
        # teammates keep the same budget: they send no faster than it allows this robot, which is no loss
        allowed = self.budget.allowed_rate_hz
        expected_hz = p.send_rate_hz if allowed is None else max(0.01, min(p.send_rate_hz, allowed))
        for rid in ids:
            self.links[rid].forget(now, p.loss_window_s)
        self.team_comm_pub.publish(schemas.make(
            TeamCommStatus, header=header(), team_id=p.team_id, player_id=min(p.player_id, 255), mate_ids=ids,
            age=[now - self.links[rid].newest for rid in ids],
            received=[min(len(self.links[rid].arrivals), 65535) for rid in ids],
            loss_pct=[self.links[rid].loss_pct(now, p.loss_window_s, expected_hz) for rid in ids],
            window_s=p.loss_window_s, expected_rate_hz=expected_hz, memory_s=p.status_memory_s,
            send_rate_hz=self.budget.send_rate_hz(now), message_budget=min(self.budget.budget_left, BUDGET_UNKNOWN),
            budget_rate_hz=-1.0 if self.budget.allowed_rate_hz is None else self.budget.allowed_rate_hz))

    # -- lifecycle ------------------------------------------------------------------------------------------
    def on_parameters_changed(self, changed: dict[str, Any]) -> None:
        if "send_rate_hz" in changed:
            self._send_timer.set_rate(self.params.send_rate_hz)
        if {"half_s", "budget_reserve"} & set(changed):
            self.budget.half_s, self.budget.reserve = self.params.half_s, self.params.budget_reserve
        if {"peers", "port", "broadcast", "hsl", "broadcast_address", "team_id", "team_port"} & set(changed):
            self._update_destinations()
        if {"team_key", "unsigned", "signature_window_s", "player_id", "team_id", "listen_address"} & set(changed):
            self.guard = self._make_guard()
        if {"listen_address", "port", "hsl", "team_id", "team_port", "team_key", "unsigned", "signature_window_s",
                "player_id"} & set(changed):
            self._close_socket()
            try:
                self._open_socket()
            except OSError as exc:
                self.record_error(f"cannot listen on {self.params.listen_address}:{self.listen_port}: {exc}")
        if {"codec", "team_id"} & set(changed):
            self.mates.clear()
            self.links.clear()

    def on_shutdown(self) -> None:
        self._close_socket()


def _position(xy: tuple[float, ...] | None, confidence: float) -> Position2D:
    x, y, theta = (*xy, 0.0)[:3] if xy is not None else (0.0, 0.0, 0.0)
    return schemas.make(Position2D, pose=Pose2D(x=float(x), y=float(y), theta=float(theta)),
                        confidence=confidence if xy is not None else 0.0)


def team_data_message(mates: list[tuple[float, TeammateReport]]) -> TeamData:
    """TeamData from (age s, report) pairs; 255 / NaN where a teammate did not say."""
    nan = float("nan")
    return schemas.make(
        TeamData,
        header=header(),
        robot_ids=[r.robot_id for _, r in mates],
        role=[NOT_TOLD if r.role is None else r.role for _, r in mates],
        action=[0 if r.action is None else r.action for _, r in mates],
        state=[NOT_TOLD if r.state is None else r.state for _, r in mates],
        offensive_side=[NOT_TOLD if r.offensive_side is None else r.offensive_side for _, r in mates],
        robot_positions=[_position(r.position, r.position_confidence) for _, r in mates],
        ball_relative=[_position(r.ball, r.ball_confidence) for _, r in mates],
        oppgoal_relative=[_position(r.oppgoal, r.oppgoal_confidence) for _, r in mates],
        avg_walking_speeds=[nan if r.walking_speed is None else r.walking_speed for _, r in mates],
        time_to_position_at_ball=[nan if r.time_to_ball is None else r.time_to_ball for _, r in mates],
        max_kicking_distance=[nan if r.max_kicking_distance is None else r.max_kicking_distance for _, r in mates],
        age=[age for age, _ in mates],
    )


def main() -> None:
    run(MitecomNode)


if __name__ == "__main__":
    main()
