"""The 3D view (viser) and the plots (rerun) are reachable only through the dashboard's origin.

Real dashboards (``python -m server``, listening on every interface), real viser and rerun servers, real sockets:
the views load and stream through the dashboard; their own servers listen on loopback only, on ports browsers
refuse, and viser closes a WebSocket that a browser opens to it directly.
"""

from __future__ import annotations

import base64
import hashlib
import re
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import psutil
import pytest
from websockets.typing import Origin, Subprotocol

from robot_nodes.runtime import BusConfig
from server.loopback_ports import BROWSER_BLOCKED_PORTS
from tests.dashboard_server import RunningServer, dashboard_server
from tests.waiting import wait_for

pytestmark = [pytest.mark.slow]
WOLFGANG_JOINTS = "HeadPan,HeadTilt,LShoulderPitch,RShoulderPitch,LElbow,RElbow,LKnee,RKnee"
GRPC_READ = "/rerun.sdk_comms.v1alpha1.MessageProxyService/ReadMessages"
GRPC_WEB = {"content-type": "application/grpc-web+proto", "x-grpc-web": "1"}
EMPTY_GRPC_REQUEST = b"\x00\x00\x00\x00\x00"  # a gRPC-web frame: data, length 0 (an empty ReadMessages request)


def lan_address() -> str | None:
    """An IPv4 address of this machine that is not loopback (where a stranger at the venue would knock)."""
    for addresses in psutil.net_if_addrs().values():
        for address in addresses:
            if address.family == socket.AF_INET and not address.address.startswith("127."):
                return str(address.address)
    return None


def refused(host: str, port: int) -> bool:
    try:
        with socket.create_connection((host, port), timeout=3):
            return False
    except OSError:
        return True


def viser_messages(frame: bytes) -> list[dict[str, Any]]:
    """The messages in one frame viser sends (its wire format: sizes, zstd-compressed msgpack, binary buffers)."""
    import msgspec
    import zstandard

    size, packed = int.from_bytes(frame[:8], "little"), int.from_bytes(frame[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(frame[16:16 + packed], max_output_size=size)
    return list(msgspec.msgpack.decode(inner)["messages"])


def camera_message() -> bytes:
    """What viser's client sends first (its camera); viser counts a client once it has one."""
    import msgspec
    from viser._messages import ViewerCameraMessage

    message = ViewerCameraMessage(wxyz=(1.0, 0.0, 0.0, 0.0), position=(1.0, -1.0, 0.6), fov=1.0, near=0.01,
                                  far=100.0, image_height=480, image_width=640, look_at=(0.0, 0.0, 0.2),
                                  up_direction=(0.0, 0.0, 1.0))
    return bytes(msgspec.msgpack.encode(message.as_serializable_dict()))


def viser_subprotocol() -> Subprotocol:
    import viser

    return Subprotocol(f"viser-v{viser.__version__}")


def _sha256_source(text: str) -> str:
    return "'sha256-" + base64.b64encode(hashlib.sha256(text.encode()).digest()).decode() + "'"


@pytest.fixture
def wolfgang_dashboard(router_endpoint: str, bus: BusConfig, testdata: Path, tmp_path: Path) -> Iterator[
        tuple[RunningServer, Any]]:
    """A dashboard on every interface with the 3D view (viser port: the default choice), and a node publishing
    the Wolfgang robot's joint_states as r1."""
    from tests.teststand import TestStand

    wolfgang = testdata / "robots" / "wolfgang"
    args = ["--connect", router_endpoint, "--no-telemetry", "--robot3d", "--robot3d-port", "0",
            "--urdf", str(wolfgang / "urdf" / "robot.urdf"), "--package", f"wolfgang_description={wolfgang}"]
    with dashboard_server(args, tmp_path, host="0.0.0.0") as server:
        node = TestStand("r1", bus, overrides={"rate_hz": 20.0, "joints": WOLFGANG_JOINTS}).start()
        try:
            yield server, node
        finally:
            node.shutdown()


def test_3d_view_loads_and_streams_through_the_dashboard_only(wolfgang_dashboard: tuple[RunningServer, Any]) -> None:
    from websockets.exceptions import ConnectionClosed
    from websockets.sync.client import connect

    server, _ = wolfgang_dashboard
    status = server.http.get(f"{server.url}/api/robot3d", timeout=10).json()
    viser_port = status["port"]
    assert server.http.get(f"{server.url}/api/config", timeout=10).json()["robot3d"] == {"view": "robot3d/view/"}

    # the page, through the dashboard: viser's client, with a policy that lets exactly its own scripts run
    page = server.http.get(f"{server.url}/robot3d/view/", timeout=30)
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    assert page.headers["x-content-type-options"] == "nosniff"
    policy = dict(d.strip().split(" ", 1) for d in page.headers["content-security-policy"].split(";"))
    assert policy["frame-ancestors"] == "'self'" and policy["default-src"] == "'self'"
    assert "'unsafe-inline'" not in policy["script-src"] and "http" not in policy["script-src"]
    loader = re.search(r"<script\b[^>]*>(.*?)</script>", page.text, re.S)
    assert loader is not None and _sha256_source(loader.group(1)) in policy["script-src"]  # the inline loader
    assert len(re.findall(r"'sha256-", policy["script-src"])) == 2  # and the script it unpacks
    assert server.http.get(f"{server.url}/robot3d/view", timeout=10, follow_redirects=True).status_code == 200
    missing = server.http.get(f"{server.url}/robot3d/view/nothing.js", timeout=10)
    assert missing.status_code == 404 and missing.headers["x-content-type-options"] == "nosniff"
    assert server.http.get(f"{server.url}/robot3d/view/..%2F..%2Fetc", timeout=10).status_code == 404

    # the WebSocket, through the dashboard: viser's scene arrives (the ground, robot r1 and its meshes), and what
    # the browser sends reaches viser (its camera makes it a client viser counts)
    ws_url = f"ws://127.0.0.1:{server.port}/robot3d/view"
    # the dashboard's guard covers the view: beyond loopback no credential, no view; no foreign page, no other name
    from websockets.exceptions import InvalidStatus

    assert httpx.get(f"{server.url}/robot3d/view/", timeout=10).status_code == 401
    for refused_by, kwargs in ((401, {}), (403, {"origin": "http://evil.example", "additional_headers": server.auth}),
                               (421, {"additional_headers": {"Host": "evil.example", **server.auth}})):
        with pytest.raises(InvalidStatus) as refusal:
            connect(ws_url, subprotocols=[viser_subprotocol()], open_timeout=10, **kwargs)
        assert refusal.value.response.status_code == refused_by
    with connect(ws_url, subprotocols=[viser_subprotocol()], max_size=None, open_timeout=10,
                 additional_headers=server.auth) as ws:
        assert ws.subprotocol == viser_subprotocol()
        ws.send(camera_message())
        names: set[str] = set()
        deadline = time.monotonic() + 60

        def scene_has_robot() -> bool:
            return "/ground" in names and "/r1" in names and any(n.startswith("/r1/") for n in names)

        while not scene_has_robot():
            assert time.monotonic() < deadline, f"robot r1 never reached the scene: {sorted(names)[:20]}"
            frame = ws.recv(timeout=30)
            assert isinstance(frame, bytes)
            names.update(m["name"] for m in viser_messages(frame) if isinstance(m.get("name"), str))
        wait_for(lambda: server.http.get(f"{server.url}/api/robot3d", timeout=10).json()["viewers"] == 1, 20.0, 0.1,
                 "viser counts the proxied browser")
    # closed on the browser's side: viser's side closes too
    wait_for(lambda: server.http.get(f"{server.url}/api/robot3d", timeout=10).json()["viewers"] == 0, 20.0, 0.1,
             "viser lets the browser go")

    # viser itself: on loopback only, on a port browsers refuse, and a browser's own WebSocket to it is closed
    # before any of the scene is sent
    assert viser_port in BROWSER_BLOCKED_PORTS
    conns = [c for c in psutil.Process(server.process.pid).net_connections(kind="inet")
             if c.status == psutil.CONN_LISTEN and c.laddr.port == viser_port]
    assert conns and all(c.laddr.ip == "127.0.0.1" for c in conns), conns
    lan = lan_address()
    if lan is not None:
        assert not refused(lan, server.port)  # the dashboard answers there (it listens on every interface) ...
        assert refused(lan, viser_port)  # ... viser does not
    direct = connect(f"ws://127.0.0.1:{viser_port}/", subprotocols=[viser_subprotocol()], max_size=None,
                     origin=Origin("https://evil.example"), open_timeout=10)
    with direct, pytest.raises(ConnectionClosed) as closed:
        direct.recv(timeout=20)
    assert closed.value.rcvd is not None and closed.value.rcvd.code == 1008


def test_plots_stream_through_the_dashboard_only(router_endpoint: str, bus: BusConfig, tmp_path: Path) -> None:
    from tests.teststand import TestStand

    args = ["--connect", router_endpoint, "--no-telemetry", "--plots", "--plots-port", "0", "--plots-grpc-port", "0"]
    with dashboard_server(args, tmp_path, host="0.0.0.0") as server:
        node = TestStand("r1", bus, overrides={"rate_hz": 20.0}).start()
        try:
            status = wait_for(lambda: (s := server.http.get(f"{server.url}/api/plots", timeout=10).json())["logged"] > 5
                              and s, 60.0, 0.2, "plots fed")
            assert status["server_running"]
            assert server.http.get(f"{server.url}/api/config", timeout=10).json()["plots"] == {
                "viewer": "plots/viewer/index.html"}

            # the viewer's page: its data only from this origin
            page = server.http.get(f"{server.url}/plots/viewer/index.html", timeout=30)
            assert page.status_code == 200 and page.headers["x-content-type-options"] == "nosniff"
            policy = page.headers["content-security-policy"]
            assert "connect-src 'self' data: blob:;" in policy and "frame-ancestors 'self'" in policy

            # the data, through the dashboard: rerun's gRPC-web stream, growing while the robot publishes
            received = bytearray()
            with server.http.stream("POST", f"{server.url}{GRPC_READ}", content=EMPTY_GRPC_REQUEST, headers=GRPC_WEB,
                              timeout=httpx.Timeout(30.0)) as stream:
                assert stream.status_code == 200 and stream.headers["content-type"] == "application/grpc-web+proto"
                assert stream.headers["x-content-type-options"] == "nosniff"
                chunks = stream.iter_raw()
                while b"pitchside" not in received:  # the recording's name and its rows so far
                    received += next(chunks)
                grown = len(received)
                while len(received) < grown + 2_000:  # new rows as they are logged
                    received += next(chunks)
            assert received[0] == 0  # a gRPC-web data frame
            # the guard covers the stream: a foreign page, or no credential, reads nothing
            foreign = server.http.post(f"{server.url}{GRPC_READ}", content=EMPTY_GRPC_REQUEST,
                                       headers={**GRPC_WEB, "Origin": "http://evil.example"}, timeout=10)
            assert foreign.status_code == 403
            anonymous = httpx.post(f"{server.url}{GRPC_READ}", content=EMPTY_GRPC_REQUEST, headers=GRPC_WEB,
                                   timeout=10)
            assert anonymous.status_code == 401
            writing = server.http.post(f"{server.url}/rerun.sdk_comms.v1alpha1.MessageProxyService/WriteMessages",
                                 content=EMPTY_GRPC_REQUEST, headers=GRPC_WEB, timeout=10)
            assert writing.status_code == 404  # no page may write into the plots
            too_big = server.http.post(f"{server.url}{GRPC_READ}", content=bytes(100_000), headers=GRPC_WEB, timeout=10)
            assert too_big.status_code == 413

            # a browser that leaves while rerun has nothing new to send: the relay to rerun ends all the same
            node.shutdown()
            node = None
            dashboard = psutil.Process(server.process.pid)

            def relays() -> int:  # the dashboard's connections to rerun's gRPC port: the SDK's, and one per read
                return sum(1 for c in dashboard.net_connections(kind="tcp")
                           if c.raddr and c.raddr.port == status["grpc_port"] and c.status == psutil.CONN_ESTABLISHED)

            idle = relays()
            with server.http.stream("POST", f"{server.url}{GRPC_READ}", content=EMPTY_GRPC_REQUEST, headers=GRPC_WEB,
                              timeout=httpx.Timeout(30.0)) as stream:
                chunks = stream.iter_raw()  # (held: a dropped iterator closes the response)
                next(chunks)
                wait_for(lambda: relays() == idle + 1, 10.0, 0.05, "the read relayed to rerun")
            wait_for(lambda: relays() == idle, 10.0, 0.05, "the relay to rerun closed with the browser's read")

            # rerun's own servers: on loopback only, the data on a port browsers refuse
            assert status["grpc_port"] in BROWSER_BLOCKED_PORTS
            rerun = [p for p in psutil.Process(server.process.pid).children() if p.name() == "rerun"]
            assert len(rerun) == 1, rerun
            listening = [c for c in rerun[0].net_connections(kind="inet") if c.status == psutil.CONN_LISTEN]
            assert {c.laddr.port for c in listening} == {status["grpc_port"], status["web_port"]}
            assert all(c.laddr.ip == "127.0.0.1" for c in listening), listening
            lan = lan_address()
            if lan is not None:
                assert not refused(lan, server.port)
                assert refused(lan, status["grpc_port"]) and refused(lan, status["web_port"])
        finally:
            if node is not None:
                node.shutdown()
    # the dashboard ended: so did rerun's server
    wait_for(lambda: not rerun[0].is_running() or rerun[0].status() == psutil.STATUS_ZOMBIE, 10.0, 0.1,
             "rerun's server stopped with the dashboard")


def test_rerun_server_dies_with_a_killed_dashboard(tmp_path: Path) -> None:
    """Even a dashboard killed outright (no shutdown) leaves no rerun server behind holding the plots' ports."""
    with dashboard_server(["--no-live", "--no-telemetry", "--plots", "--plots-port", "0", "--plots-grpc-port", "0"],
                          tmp_path) as server:
        rerun = wait_for(lambda: [p for p in psutil.Process(server.process.pid).children() if p.name() == "rerun"],
                         30.0, 0.1, "rerun's server started")
        server.process.kill()
        server.process.wait(10)
        wait_for(lambda: not rerun[0].is_running() or rerun[0].status() == psutil.STATUS_ZOMBIE, 10.0, 0.1,
                 "rerun's server ended with the dashboard")


@pytest.mark.browser
def test_a_web_page_cannot_reach_the_views_own_servers(browser: Any, tmp_path: Path) -> None:
    """Loopback is reachable from the laptop's browser: the ports themselves must be ones the browser refuses."""
    args = ["--no-live", "--no-telemetry", "--robot3d", "--robot3d-port", "0", "--plots", "--plots-port", "0",
            "--plots-grpc-port", "0"]
    with dashboard_server(args, tmp_path) as server:
        viser_port = httpx.get(f"{server.url}/api/robot3d", timeout=10).json()["port"]
        plots = httpx.get(f"{server.url}/api/plots", timeout=10).json()
        grpc_port, web_port = plots["grpc_port"], plots["web_port"]
        # rerun's file server answers any Host: a rebinding page could load the viewer from a port it may open
        assert {viser_port, grpc_port, web_port} <= set(BROWSER_BLOCKED_PORTS)
        page = browser.new_page()
        try:
            page.goto(f"{server.url}/api/config")  # any page: a foreign one would do the same
            reach = """async (url) => { try { await fetch(url, {mode: 'no-cors'}); return 'reached'; }
                                        catch (e) { return 'refused'; } }"""
            assert page.evaluate(reach, f"{server.url}/api/config") == "reached"  # fetch itself works here
            assert page.evaluate(reach, f"http://127.0.0.1:{grpc_port}{GRPC_READ}") == "refused"
            assert page.evaluate(reach, f"http://127.0.0.1:{viser_port}/") == "refused"
            assert page.evaluate(reach, f"http://127.0.0.1:{web_port}/") == "refused"
            opened = """(url) => new Promise((done) => { const ws = new WebSocket(url, ['%s']);
                          ws.onopen = () => { ws.close(); done('opened'); }; ws.onerror = () => done('refused'); })"""
            assert page.evaluate(opened % viser_subprotocol(), f"ws://127.0.0.1:{server.port}/robot3d/view") == \
                "opened"  # through the dashboard
            assert page.evaluate(opened % viser_subprotocol(), f"ws://127.0.0.1:{viser_port}/") == "refused"
        finally:
            page.close()


def test_a_slow_browser_holds_back_viser_instead_of_filling_the_proxy(testdata: Path) -> None:
    """A browser that stops reading while viser sends 300 MB: the dashboard's memory stays put, and the
    connection goes on once the browser reads again; viser closing closes the browser's socket."""
    import uvicorn
    from websockets.exceptions import ConnectionClosed
    from websockets.sync.client import connect

    from server.app import create_app
    from server.config import ServerConfig
    from tests.support import free_port

    port = free_port()
    app = create_app(ServerConfig(port=port, live_source=False, telemetry_source=False, robot3d=True,
                                  robot3d_port=0))
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    try:
        wait_for(lambda: server.started, 30.0, 0.05, "dashboard up")
        view = app.state.pitchside.robot3d
        me = psutil.Process()
        with connect(f"ws://127.0.0.1:{port}/robot3d/view", subprotocols=[viser_subprotocol()], max_size=None,
                     max_queue=1, open_timeout=10) as ws:
            ws.recv(timeout=30)  # the scene so far: the browser is there
            before = me.memory_info().rss
            points = np.random.default_rng(0).random((200_000, 3), dtype=np.float32)  # 2.4 MB a message
            colors = np.zeros((200_000, 3), dtype=np.uint8)
            for i in range(120):  # about 300 MB, while the browser reads nothing; paced so that viser sends each
                view.server.scene.add_point_cloud("/flood", points=points + i, colors=colors)  # (it keeps the last)
                time.sleep(0.03)
            time.sleep(2.0)  # whatever the proxy would hoard has arrived by now
            grown_mb = (me.memory_info().rss - before) / 1e6
            assert grown_mb < 120, f"the dashboard grew {grown_mb:.0f} MB while a browser did not read"
            deadline = time.monotonic() + 60
            while time.monotonic() < deadline:  # reading again: frames come (the newest flood among them)
                frame = ws.recv(timeout=30)
                if any(m.get("name") == "/flood" for m in viser_messages(frame)):  # type: ignore[arg-type]
                    break
            else:
                raise AssertionError("no flood frame after reading again")
            # viser drops its connections: the browser's socket through the proxy closes too
            view.server._websock_server.disconnect_all_clients()
            with pytest.raises(ConnectionClosed):
                while True:
                    ws.recv(timeout=20)
        print(f"\ndashboard grew {grown_mb:.0f} MB while a browser read none of 120 x 2.4 MB scene updates")
    finally:
        server.should_exit = True
        thread.join(30)
