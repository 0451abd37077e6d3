"""GameController receiver node: GC state packets on UDP -> `gamestate`, and return packets to the GC, in the
version the GameController speaks.

To an HSL GameController (v19/v20) the node sends the RGrt v4 status packet at 0.5-2 Hz: fallen from the HCM
(`robot_state`), the pose from `position` and the newest ball from `ball_relative` (module status).

To an HL v12 GameController it sends the v2 return packet. It says ALIVE; while the robot is manually penalised
(`manual_penalty`, from the pause logic: its button or the manual_penalize service) it says MAN_PENALISE, and when
that ends MAN_UNPENALISE (at least UNPENALISE_AT_LEAST of them) until the GameController no longer reports the
robot penalised (at most UNPENALISE_PACKETS of them), then ALIVE again. The GameController acts when a robot's
message changes, so a lost packet is made good by the next one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import schemas
from robot_nodes.game_controller.fake_state import WhistleStart
from robot_nodes.game_controller.status import RobotStatus, status_rate_hz
from robot_nodes.ground_pose import OWN_HALF_DOC, OWN_HALVES
from robot_nodes.runtime import Node, header, param, run
from robot_nodes.runtime.udp import UdpPort
from schemas.messages import BallRelative, GameState, Position2D, RobotControlState
from schemas.std import Bool
from wire.gamecontroller.gamestate import MESSAGE_BUDGET_UNKNOWN, allowed_to_move, gamestate_fields
from wire.gamecontroller.packets import (
    DATA_PORT,
    RETURN_PORT,
    GameControlData,
    GameControllerPacketError,
    ReturnMessage,
    RobotInfo,
    build_return_packet,
    build_status_packet,
    parse_state_packet,
)

__all__ = ["MESSAGE_BUDGET_UNKNOWN", "GameControllerNode", "GameControllerParams", "allowed_to_move",
           "gamestate_fields", "main"]

BAD_PACKET_KINDS = ("truncated", "over_long", "wrong_header", "wrong_version", "bad_value")
UNPENALISE_PACKETS = 6  # MAN_UNPENALISE packets at most after a manual penalty ends (3 s at the usual 2 Hz)
# MAN_UNPENALISE packets sent whatever the GameController last said: its state packets tell a penalty it gave only
# a packet later, so a button pressed and released within that time would otherwise end in ALIVE, and the
# GameController, acting on MAN_PENALISE, would keep the robot penalised for good
UNPENALISE_AT_LEAST = 2
_RECV_SIZE = 2048  # larger than any GC packet, so oversized datagrams arrive whole and are rejected by size


@dataclass
class GameControllerParams:
    team_number: int = param(1, range=(1, 255), doc="our team number as configured in the GameController")
    player_number: int = param(1, range=(1, 20), doc="this robot's player number (1-based)")
    listen_address: str = param("0.0.0.0", doc="address to receive GC packets on (0.0.0.0: every interface)")
    listen_port: int = param(DATA_PORT, range=(1, 65535), doc="UDP port the GC broadcasts to")
    return_port: int = param(RETURN_PORT, range=(1, 65535), doc="UDP port of the GC for return packets")
    return_rate_hz: float = param(2.0, range=(0.1, 10.0), doc="rate of ALIVE return packets to the GC")
    keepalive_hz: float = param(1.0, range=(0.1, 10.0), doc="republish an unchanged gamestate at this rate")
    gc_timeout_s: float = param(5.0, range=(0.5, 60.0), doc="after this silence the GC counts as lost")
    own_half: str = param("-x", choices=OWN_HALVES, doc=OWN_HALF_DOC)
    whistle_hold_s: float = param(10.0, range=(0.0, 15.0),
                                  doc="a whistle heard in SET means PLAYING for up to this long while the GC still "
                                      "says SET (its delayed state); 0: only the GC's state counts")


class GameControllerNode(Node):
    """Listens to the RoboCup GameController and tells the team's nodes the game state."""

    name = "game_controller"
    Params = GameControllerParams

    def setup(self) -> None:
        self.gamestate_pub = self.publisher("gamestate")
        self.packets = 0
        self.bad_packets = 0
        self.foreign_packets = 0
        self.bad_by_kind: dict[str, int] = {}  # GameControllerPacketError.kind -> count
        self.returns_sent = 0
        self.gc_address: str | None = None
        self.last_data: GameControlData | None = None
        self._last_fields: dict[str, Any] | None = None  # as published
        self._gc_fields: dict[str, Any] | None = None  # as the GameController says
        self.whistle = WhistleStart(hold_s=self.params.whistle_hold_s)
        self.whistles_heard = 0
        self._last_packet_time = 0.0
        self._last_publish_time = 0.0
        self._udp: UdpPort | None = None
        self.manual_penalty = False
        self._unpenalise_left = 0  # MAN_UNPENALISE packets still to send
        self._open_socket()
        self._return_timer = self.timer(self._send_return, rate_hz=self.params.return_rate_hz, name="return_packets")
        self._keepalive_timer = self.timer(self._keepalive, rate_hz=10.0, name="keepalive")
        self._idle()  # both timers wait for the first packet of a GameController
        self.subscribe("manual_penalty", self._on_manual_penalty)
        self.subscribe("whistle", self._on_whistle)
        self.status = RobotStatus(self.params.own_half)  # what an HSL GameController's status packet says
        self.subscribe("robot_state", self._on_robot_state)
        self.subscribe("position", self._on_position)
        self.subscribe("ball_relative", self._on_ball)
        self._update_diagnostics()

    # -- socket ---------------------------------------------------------------------------------------------
    def _open_socket(self) -> None:
        # address reuse: `pitchside doctor` listens beside the running node for the GameController's broadcasts
        self._udp = UdpPort(self.params.listen_address, self.params.listen_port,
                            lambda data, addr: self._on_datagram(data, addr[0]), loop=self.loop,
                            recv_size=_RECV_SIZE, name="gc-receiver", reuse_address=True)

    def _close_socket(self) -> None:
        if self._udp is not None:
            self._udp.close()
        self._udp = None

    @property
    def listen_port(self) -> int:
        """The bound port (useful when listen_port was given as a free port)."""
        return self._udp.port if self._udp is not None else 0

    # -- packets --------------------------------------------------------------------------------------------
    def _on_datagram(self, data: bytes, sender: str) -> None:
        try:
            packet = parse_state_packet(data)
        except GameControllerPacketError as exc:
            self.bad_packets += 1
            self.bad_by_kind[exc.kind] = self.bad_by_kind.get(exc.kind, 0) + 1
            self.record_error(f"bad GameController packet from {sender}: {exc}")
            self._update_diagnostics()
            return
        fields = gamestate_fields(packet, self.params.team_number, self.params.player_number)
        if fields is None:
            self.foreign_packets += 1
            self._update_diagnostics()
            return
        self.packets += 1
        self.gc_address = sender
        if self.last_data is None or self.last_data.hsl != packet.hsl:
            self.last_data = packet
            self._return_timer.set_rate(self._return_rate_hz())
        self.last_data = packet
        self._last_packet_time = self.now()
        self._keepalive_timer.resume(at_once=False)
        self._return_timer.resume(at_once=False)
        self._gc_fields = fields
        self._tell(fields)
        self._update_diagnostics()

    def _tell(self, gc_fields: dict[str, Any]) -> None:
        """Publishes at once what changed: the GameController's fields, PLAYING on a whistle ahead of them."""
        fields = self.whistle.apply(gc_fields, self.now())
        if fields != self._last_fields:
            self._last_fields = fields
            self._publish()

    def _on_whistle(self, msg: Bool) -> None:
        if not msg.data:
            return
        gc_state = self._gc_fields["game_state"] if self._gc_fields is not None else None
        if self.whistle.on_whistle(self.now(), gc_state) and self._gc_fields is not None:
            self._tell(self._gc_fields)
        self.whistles_heard += 1
        self.set_diagnostic("whistles_heard", self.whistles_heard)

    def _publish(self) -> None:
        if self._last_fields is None:
            return
        self.gamestate_pub.publish(schemas.make(GameState, header=header(),
                                                **self._last_fields))
        self._last_publish_time = self.now()

    def _keepalive(self) -> None:
        """Republish an unchanged state so late joiners learn it; stop once the GC is lost."""
        now = self.now()
        if self._last_fields is None or now - self._last_packet_time > self.params.gc_timeout_s:
            self._idle()
            return
        if self._gc_fields is not None and self.whistle.heard_at is not None:
            self._tell(self._gc_fields)  # a whistle's PLAYING ends after hold_s
        if now - self._last_publish_time >= 1.0 / self.params.keepalive_hz:
            self._publish()

    def _idle(self) -> None:
        """No GameController heard (yet, or for gc_timeout_s): nothing to republish or answer until one is."""
        self._keepalive_timer.pause()
        self._return_timer.pause()

    def _on_manual_penalty(self, msg: Bool) -> None:
        manual = bool(msg.data)
        if manual == self.manual_penalty:
            return
        self.manual_penalty = manual
        self._unpenalise_left = 0 if manual else UNPENALISE_PACKETS
        if self.last_data is None or not self.last_data.hsl:  # an HSL GC has no manual penalty to tell at once
            self._send_return()  # tell the GameController now, not at the next tick

    def return_message(self) -> ReturnMessage:
        """What the next return packet says (see the module's docstring)."""
        if self.manual_penalty:
            return ReturnMessage.MAN_PENALISE
        if self._unpenalise_left > 0:
            me = self._own_slot()
            sent = UNPENALISE_PACKETS - self._unpenalise_left
            if sent < UNPENALISE_AT_LEAST or (me is not None and me.penalized):
                return ReturnMessage.MAN_UNPENALISE
            self._unpenalise_left = 0  # the GameController has let the robot play again
        return ReturnMessage.ALIVE

    def _own_slot(self) -> RobotInfo | None:
        own = self.last_data.team(self.params.team_number) if self.last_data is not None else None
        return own.player(self.params.player_number) if own is not None else None

    def _on_robot_state(self, msg: RobotControlState) -> None:
        self.status.on_robot_state(msg)

    def _on_position(self, msg: Position2D) -> None:
        self.status.on_position(msg)

    def _on_ball(self, msg: BallRelative) -> None:
        self.status.on_ball(msg, self.now())

    def _return_rate_hz(self) -> float:
        """return_rate_hz, within 0.5-2 Hz for an HSL GameController (its rule for status packets)."""
        hsl = self.last_data is not None and self.last_data.hsl
        return status_rate_hz(self.params.return_rate_hz) if hsl else self.params.return_rate_hz

    def _send_return(self) -> None:
        """To a v12 GameController the HL v2 return packet; to a v19/v20 one the v4 status packet (the HSL
        GameController has no manual penalty: a robot's own penalty is the referee's call there)."""
        if self.gc_address is None or self._udp is None or self.last_data is None:
            return
        if self.now() - self._last_packet_time > self.params.gc_timeout_s:
            return
        hsl = self.last_data.hsl
        message = self.return_message()
        if hsl:
            packet = build_status_packet(self.status.packet(self.params.team_number, self.params.player_number,
                                                            self.now()))
        else:
            packet = build_return_packet(self.params.team_number, self.params.player_number, message)
        try:
            self._udp.sendto(packet, (self.gc_address, self.params.return_port))
            self.returns_sent += 1
            if message == ReturnMessage.MAN_UNPENALISE and not hsl:
                self._unpenalise_left -= 1
            self.set_diagnostic("return_packets_sent", self.returns_sent)
            self.set_diagnostic("return_message", "STATUS_V4" if hsl else message.name)
        except OSError as exc:
            self.record_error(f"cannot send return packet to {self.gc_address}:{self.params.return_port}: {exc}")

    def _update_diagnostics(self) -> None:
        self.set_diagnostic("packets", self.packets)
        self.set_diagnostic("bad_packets", self.bad_packets)
        self.set_diagnostic("foreign_packets", self.foreign_packets)
        for kind in BAD_PACKET_KINDS:
            self.set_diagnostic(f"bad_packets_{kind}", self.bad_by_kind.get(kind, 0))
        self.set_diagnostic("gc_version", self.last_data.version if self.last_data is not None else "")
        self.set_diagnostic("return_packets_sent", self.returns_sent)
        self.set_diagnostic("gc_address", self.gc_address or "")

    # -- lifecycle ------------------------------------------------------------------------------------------
    def on_parameters_changed(self, changed: dict[str, Any]) -> None:
        if "return_rate_hz" in changed:
            self._return_timer.set_rate(self._return_rate_hz())
        if "own_half" in changed:
            self.status.own_half = self.params.own_half
        if "whistle_hold_s" in changed:
            self.whistle.hold_s = self.params.whistle_hold_s
        if {"team_number", "player_number"} & set(changed):
            self._last_fields = None  # the next packet is published whatever it says
        if {"listen_address", "listen_port"} & set(changed):
            self._close_socket()
            try:
                self._open_socket()
            except OSError as exc:
                self.record_error(f"cannot listen on {self.params.listen_address}:{self.params.listen_port}: {exc}")

    def on_shutdown(self) -> None:
        self._close_socket()


def main() -> None:
    run(GameControllerNode)


if __name__ == "__main__":
    main()
