"""Match mode: the server sends nothing to any robot and refuses control; off loopback control needs the token."""

from __future__ import annotations

import json
import re
import socket
from pathlib import Path
from typing import Any

import httpx
import psutil
import pytest

from robot_nodes.runtime import BusConfig
from server.loopback_ports import BROWSER_BLOCKED_PORTS
from tests.dashboard_server import RunningServer, dashboard_server
from tests.foxglove_node import foxglove_url
from tests.support import free_port
from tests.teststand import TestStand
from tests.waiting import wait_for

DUMMY_BODIES = {"/params/{node}": {"values": {"rate_hz": 10}}, "/penalize": {"penalize": "on"},
                "/animation-play": {"animation": "stand"}}


def control_calls(server: RunningServer) -> list[tuple[str, str, dict[str, Any] | None]]:
    """Every endpoint that acts on a robot (control, parameters, animations, teleop: all of /api/robots/{robot}/),
    read from the running server's own OpenAPI description, so endpoints added later are covered too."""
    spec = httpx.get(f"{server.url}/openapi.json").json()
    calls = []
    for path, methods in spec["paths"].items():
        for method, op in methods.items():
            if "control" in op.get("tags", []) or path.startswith("/api/robots/{robot}/"):
                concrete = path.replace("{robot}", "r7").replace("{node}", "teststand").replace("{file}", "stand")
                body = next((b for suffix, b in DUMMY_BODIES.items() if path.endswith(suffix)), None)
                calls.append((method.upper(), concrete, body if method == "post" else None))
    assert len(calls) >= 5, calls  # params list/get/set, penalize, animation
    return calls


def robot_overview_datagrams(robot: str) -> list[bytes]:
    datagram = pytest.importorskip("wire.telemetry.datagram")
    writer = datagram.DatagramWriter(datagram.load_key(None), robot)
    overview = datagram.new_overview(hcm_state=10, pose_known=True, pose_x=1.5)
    return writer.message(datagram.Kind.OVERVIEW, datagram.OVERVIEW_STREAM, datagram.OVERVIEW_HASH,
                          datagram.encode_overview(overview))


def test_match_mode_refuses_control_and_sends_nothing(router_endpoint: str, tmp_path: Path) -> None:
    telemetry_port = free_port(socket.SOCK_DGRAM)
    robot = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)  # where a robot would be: it sends from here
    robot.bind(("127.0.0.1", 0))
    robot.settimeout(1.0)
    router_port = int(router_endpoint.rsplit(":", 1)[1])
    args = ["--match", "--allow-dev-key", "--connect", router_endpoint, "--telemetry-host", "127.0.0.1",
            "--telemetry-port", str(telemetry_port)]
    try:
        with dashboard_server(args, tmp_path) as server:
            assert "MATCH MODE" in server.output()
            # the passive telemetry source works: the robot shows up
            for packet in robot_overview_datagrams("r7"):
                robot.sendto(packet, ("127.0.0.1", telemetry_port))
            listed = wait_for(lambda: httpx.get(f"{server.url}/api/robots").json(), 20.0, 0.1, "robot r7 listed")
            assert listed[0]["robot"] == "r7" and listed[0]["streams"]["overview"]["source"] == "telemetry"

            for method, path, body in control_calls(server):  # even with the credential
                reply = server.http.request(method, server.url + path, json=body, timeout=10)
                assert reply.status_code == 403, (method, path, reply.text)
                assert "match mode" in reply.json()["detail"]
            reply = server.http.post(f"{server.url}/api/sources/live", json={"enabled": True})
            assert reply.status_code == 403 and "match mode" in reply.json()["detail"]
            live = next(s for s in httpx.get(f"{server.url}/api/sources").json() if s["name"] == "live")
            assert live["running"] is False and live["zenoh_open"] is False

            _assert_only_listening(server, telemetry_port, router_port)
            with pytest.raises(TimeoutError):
                data, sender = robot.recvfrom(65536)
                raise AssertionError(f"the server sent {len(data)} bytes to the robot from {sender}")
    finally:
        robot.close()


def _assert_only_listening(server: RunningServer, telemetry_port: int, router_port: int) -> None:
    """Socket level: the HTTP listener, the telemetry listener and our own HTTP clients, nothing else."""
    conns = psutil.Process(server.process.pid).net_connections(kind="inet")
    udp = [c for c in conns if c.type == socket.SOCK_DGRAM]
    tcp = [c for c in conns if c.type == socket.SOCK_STREAM]
    assert [c.laddr.port for c in udp] == [telemetry_port], udp
    assert all(not c.raddr for c in udp), f"a UDP socket is connected somewhere: {udp}"
    foxglove = foxglove_url(server.output())  # the Foxglove endpoint listens too (server.foxglove)
    ours = {server.port, int(foxglove.rsplit(":", 1)[1]) if foxglove else server.port}
    for c in tcp:
        if c.status == psutil.CONN_LISTEN and c.laddr.ip == "127.0.0.1" and c.laddr.port in BROWSER_BLOCKED_PORTS:
            continue  # an internal server (the Foxglove SDK behind its guard)
        assert c.laddr.port in ours, f"outgoing TCP connection {c}"  # listener or an accepted client
        assert not c.raddr or c.raddr.port != router_port, f"connected to the Zenoh router: {c}"


def test_websocket_hello_tells_match_mode(tmp_path: Path) -> None:
    websockets = pytest.importorskip("websockets.sync.client")
    args = ["--match", "--allow-dev-key", "--telemetry-host", "127.0.0.1",
            "--telemetry-port", str(free_port(socket.SOCK_DGRAM))]
    with dashboard_server(args, tmp_path) as server, websockets.connect(server.ws_url) as ws:
        hello = json.loads(ws.recv(timeout=10))
        assert hello["type"] == "hello" and hello["match_mode"] is True


def test_token_needed_off_loopback(router_endpoint: str, bus: BusConfig, tmp_path: Path) -> None:
    node = TestStand("r1", bus).start()
    try:
        args = ["--connect", router_endpoint, "--no-telemetry"]
        with dashboard_server(args, tmp_path, host="0.0.0.0") as server:
            match = re.search(r"control token: (\S+)", server.output())
            assert match, server.output()
            token = match.group(1)
            url = f"{server.url}/api/robots/r1/params/teststand"
            for headers in ({}, {"Authorization": "Bearer wrong"}):
                reply = httpx.get(url, headers=headers, timeout=10)
                assert reply.status_code == 401 and "token" in reply.json()["detail"]
            reply = httpx.post(f"{server.url}/api/sources/live", json={"enabled": False}, timeout=10)
            assert reply.status_code == 401
            reply = httpx.get(url, headers={"Authorization": f"Bearer {token}"}, timeout=15)
            assert reply.status_code == 200, reply.text
            assert {p["name"] for p in reply.json()} >= {"rate_hz", "image_hz"}
            bearer = {"Authorization": f"Bearer {token}"}
            reply = httpx.post(url, headers=bearer, json={"values": {"rate_hz": 5000}}, timeout=15)
            assert reply.status_code == 422 and "rate_hz" in reply.json()["detail"]  # the node's own reason
            reply = httpx.post(url, headers=bearer, json={"values": {"rate_hz": 20.0}}, timeout=15)
            assert reply.status_code == 200 and reply.json()["changed"] == ["rate_hz"]
            wait_for(lambda: node.params.rate_hz == 20.0, 10.0, what="parameter applied on the node")
            # beyond loopback, reading data needs the token too; the page's config stays open (it shows the lock)
            assert httpx.get(f"{server.url}/api/robots", timeout=10).status_code == 401
            assert httpx.get(f"{server.url}/api/robots", headers=bearer, timeout=10).status_code == 200
            assert httpx.get(f"{server.url}/api/config", timeout=10).json()["control"] is False
    finally:
        node.shutdown()


def test_the_demo_in_match_mode_renders_no_more_images_than_telemetry_sends() -> None:
    """The dashboard in match mode sees the head camera only through telemetry (2 images a second by default)."""
    from pitchside.demo import demo_processes
    from pitchside.local_run import DashboardPlan
    from robot_nodes.telemetry.sender import DEFAULT_TOPICS, IMAGE_TOPIC, parse_topics

    def world_argv(match: bool) -> list[str]:
        processes = demo_processes(robots=2, endpoint="tcp/127.0.0.1:7447", http_port=8080,
                                   dashboard=DashboardPlan(5800, 5801, 5802, 5803), model="minibot", match=match,
                                   gc_ports=[3838, 3839], gc_return_port=3939)
        return next(p.argv for p in processes if p.name == "world")

    rate = parse_topics(DEFAULT_TOPICS)[IMAGE_TOPIC]
    assert f"image_rate={rate}" in world_argv(match=True) and rate < 10.0
    assert not any(arg.startswith("image_rate=") for arg in world_argv(match=False))  # the lab: every frame
