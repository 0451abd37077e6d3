"""The monitor interface of the HSL GameController, against a fake GameController that follows its README: a
monitor's RGTr request on 3636 registers it; it gets the true state as RGTD packets on its port 3838 and every
robot's status packet forwarded on its port 3940 behind the robot's IPv4 address; hosts that sent status packets
(robots) are refused as monitors."""

from __future__ import annotations

import math
import socket
import struct
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.support import free_port
from tests.test_gamecontroller_hsl import spec_packet
from tests.waiting import wait_for
from wire.gamecontroller.monitor import (
    MONITOR_REQUEST,
    GameControllerMonitor,
    parse_forwarded_status,
    parse_true_data,
)
from wire.gamecontroller.packets import GameControllerPacketError, StatusPacket, build_status_packet

MONITOR_HOST, ROBOT_HOST, GC_HOST = "127.0.0.2", "127.0.0.3", "127.0.0.1"


class FakeHslGameController:
    """The README's monitor rules, nothing more; the monitor's ports are given (3838 and 3940 on a field)."""

    def __init__(self, monitor_data_port: int, monitor_forward_port: int) -> None:
        self.requests = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.requests.bind((GC_HOST, 0))
        self.status = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.status.bind((GC_HOST, 0))
        self.out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.ports = (monitor_data_port, monitor_forward_port)
        self.monitors: set[str] = set()
        self.robots: set[str] = set()
        self.refused: list[str] = []
        self._threads = [threading.Thread(target=self._serve, args=(s, h), daemon=True)
                         for s, h in ((self.requests, self._on_request), (self.status, self._on_status))]
        for t in self._threads:
            t.start()

    def _serve(self, sock: socket.socket, handler: object) -> None:
        while True:
            try:
                data, addr = sock.recvfrom(2048)
            except OSError:
                return
            handler(data, addr[0])  # type: ignore[operator]

    def _on_request(self, data: bytes, host: str) -> None:
        if data != b"RGTr\x00":
            return
        if host in self.robots:
            self.refused.append(host)  # robots get no true data
        else:
            self.monitors.add(host)

    def _on_status(self, data: bytes, host: str) -> None:
        self.robots.add(host)
        self.monitors.discard(host)
        for monitor in self.monitors:  # forwarded unvalidated, behind the sender's address
            self.out.sendto(socket.inet_aton(host) + data, (monitor, self.ports[1]))

    def send_true_state(self, control_packet: bytes) -> None:
        for monitor in self.monitors:
            self.out.sendto(b"RGTD" + control_packet[4:], (monitor, self.ports[0]))

    def close(self) -> None:
        for s in (self.requests, self.status, self.out):
            s.close()


@pytest.fixture
def fake_gc() -> Iterator[FakeHslGameController]:
    gc = FakeHslGameController(free_port(socket.SOCK_DGRAM), free_port(socket.SOCK_DGRAM))
    yield gc
    gc.close()


def test_monitor_registers_and_sees_the_true_state_and_every_robot(fake_gc: FakeHslGameController) -> None:
    data_port, forward_port = fake_gc.ports
    with GameControllerMonitor(GC_HOST, fake_gc.requests.getsockname()[1], MONITOR_HOST, data_port, forward_port,
                               request_period_s=0.2) as monitor:
        wait_for(lambda: MONITOR_HOST in fake_gc.monitors, 10, what="the monitor registered")
        truth = spec_packet(state=3, secs=300, own_budget=11_000)
        wait_for(lambda: fake_gc.send_true_state(truth) or monitor.latest(), 10, interval=0.2,
                 what="the true state")
        latest = monitor.latest()
        assert latest is not None and (latest.version, latest.state, latest.secs_remaining) == (20, 3, 300)
        assert latest.team(13).message_budget == 11_000  # type: ignore[union-attr]

        status = StatusPacket(team=13, player=3, fallen=1, pose_mm=(-1500.0, 750.0, 0.5), ball_age_s=0.25,
                              ball_mm=(250.0, -500.0))
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as robot:
            robot.bind((ROBOT_HOST, 0))
            seen = wait_for(lambda: robot.sendto(build_status_packet(status), fake_gc.status.getsockname())
                            and monitor.robots().get((13, 3)), 10, interval=0.2, what="a forwarded status")
            assert seen.address == ROBOT_HOST and seen.status == status
            # a robot's host asking to be a monitor is refused by the GameController
            robot.sendto(MONITOR_REQUEST, fake_gc.requests.getsockname())
            wait_for(lambda: fake_gc.refused == [ROBOT_HOST], 10, what="the robot refused as a monitor")
        # bad datagrams on the monitor's ports are counted, never fatal
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as other:
            other.sendto(truth, (MONITOR_HOST, data_port))  # RGme: a robots' packet, not monitor data
            other.sendto(b"\x7f\x00\x00\x03RGrt\x04" + bytes(10), (MONITOR_HOST, forward_port))
        wait_for(lambda: monitor.counts.bad_packets == 2, 10, what="bad packets counted")
        assert monitor.counts.true_packets >= 1 and monitor.requests_sent >= 1


def test_monitor_packets_decode_and_refuse() -> None:
    raw = spec_packet(state=2)
    assert parse_true_data(b"RGTD" + raw[4:]).state == 2
    with pytest.raises(GameControllerPacketError, match="monitor data header"):
        parse_true_data(raw)
    status = build_status_packet(StatusPacket(team=5, player=2, fallen=0))
    address, back = parse_forwarded_status(bytes([10, 0, 13, 17]) + status)
    assert address == "10.0.13.17" and (back.team, back.player, back.fallen) == (5, 2, 0)
    for bad in (b"\x0a\x00", bytes(4) + status[:-1], bytes(4) + b"RGrt\x02\x05\x02\x02"):
        with pytest.raises(GameControllerPacketError):
            parse_forwarded_status(bad)
    assert struct.unpack_from("<f", status, 20)[0] == -1.0  # a ball never seen


def test_the_dashboard_shows_both_teams_as_the_monitor_sees_them(fake_gc: FakeHslGameController,
                                                                 tmp_path: Path) -> None:
    """pitchside serve --gc-monitor HOST, in match mode: each robot that sends a status appears as gc<team>-<player>
    with the true gamestate, its position on the field view (the second team turned half round), fallen, ball."""
    from fastapi.testclient import TestClient

    from server.app import create_app
    from server.config import ServerConfig
    data_port, forward_port = fake_gc.ports
    config = ServerConfig(match_mode=True, allow_dev_key=True, live_source=False, telemetry_source=False,
                          recordings_dir=tmp_path,
                          foxglove_port=None, gc_monitor=GC_HOST,
                          gc_monitor_ports=(fake_gc.requests.getsockname()[1], data_port, forward_port))
    app = create_app(config)
    hub = app.state.pitchside.hub
    truth = spec_packet(state=3, own_budget=10_500, rival_budget=11_200)  # teams: 13 (first), 7 (second)
    statuses = {(13, 3): StatusPacket(13, 3, 1, (-1500.0, 750.0, 0.5), 0.5, (250.0, -500.0)),
                (7, 2): StatusPacket(7, 2, 0, (1000.0, 500.0, 0.0), -1.0, (0.0, 0.0))}
    with TestClient(app, base_url="http://127.0.0.1", headers={"Authorization": f"Bearer {config.token}"}) as http, \
            socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as robot:
        robot.bind((ROBOT_HOST, 0))
        wait_for(lambda: fake_gc.monitors, 10, what="the dashboard registered as a monitor")

        def tell() -> object:
            fake_gc.send_true_state(truth)
            for status in statuses.values():
                robot.sendto(build_status_packet(status), fake_gc.status.getsockname())
            return all((r, t) in hub.latest for r in ("gc13-3", "gc7-2") for t in ("gamestate", "position"))

        wait_for(tell, 10, interval=0.2, what="both robots on the dashboard")
        first, second = hub.latest[("gc13-3", "position")].data.pose, hub.latest[("gc7-2", "position")].data.pose
        assert (first.x, first.y, first.theta) == pytest.approx((-1.5, 0.75, 0.5))
        assert (second.x, second.y) == pytest.approx((-1.0, -0.5)) and abs(second.theta) == pytest.approx(math.pi)
        game = hub.latest[("gc13-3", "gamestate")].data
        assert (game.version, game.game_state, game.message_budget, game.rival_message_budget) == (20, 3, 10_500,
                                                                                                   11_200)
        assert hub.latest[("gc7-2", "gamestate")].data.message_budget == 11_200
        assert hub.latest[("gc13-3", "robot_state")].data.state == 2  # FALLEN
        ball = hub.latest[("gc13-3", "ball_relative")].data.ball_relative
        assert (ball.x, ball.y) == pytest.approx((0.25, -0.5))
        assert ("gc7-2", "ball_relative") not in hub.latest  # it never saw the ball
        status = next(s for s in http.get("/api/sources").json() if s["name"] == "gc_monitor")
        assert status["running"] and status["robots"] == 2 and status["true_packets"] >= 1
