"""Attacks on the dashboard at the venue, each against a real server (uvicorn subprocess) as a foreign page, a
rebinding DNS name, a stranger on the network or a careless script would make them. Each would succeed on a
server without the VenueGuard (DESIGN.md section 11)."""

from __future__ import annotations

import json
import os
import re
import socket
import stat
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import psutil
import pytest
import uvicorn
import websockets.sync.client as ws_client
import zenoh
from fastapi.routing import APIRoute
from websockets.exceptions import InvalidStatus

from server.app import create_app
from server.config import ServerConfig
from server.security.token_file import read_token_file, token_path, write_token_file
from tests.dashboard_server import RunningServer, dashboard_server
from tests.running_demo import running_demo
from tests.support import REPO, free_port
from tests.waiting import wait_for
from wire import keys
from wire.machine import is_loopback, machine_addresses

EVIL = "http://evil.example"
BODIES: dict[str, Any] = {"/params/{node}": {"values": {"rate_hz": 10}}, "/penalize": {"penalize": "on"},
                          "/animation-play": {"animation": "stand"}, "/teleop": {"x": 0.1}, "/open": {"path": "x.mcap"}}


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RunningServer]:
    folder = tmp_path_factory.mktemp("venue")
    (folder / "rec").mkdir()
    with dashboard_server(["--no-live", "--no-telemetry", "--recordings", str(folder / "rec")], folder) as running:
        yield running


def unsafe_calls(server: RunningServer) -> list[tuple[str, str, Any]]:
    """Every state-changing endpoint of the running server, from its own OpenAPI description (later ones too)."""
    spec = server.http.get(f"{server.url}/openapi.json").json()
    calls = []
    for path, methods in spec["paths"].items():
        for method in methods:
            if method.upper() in ("POST", "PUT", "DELETE", "PATCH") and path != "/api/session":
                concrete = (path.replace("{robot}", "r1").replace("{node}", "hcm").replace("{file:path}", "wave")
                            .replace("{name}", "live"))
                body = next((b for suffix, b in BODIES.items() if path.endswith(suffix)), None)
                calls.append((method.upper(), concrete, body))
    assert len(calls) >= 25, calls  # control, animations, teleop, recordings, replay, sources, plots
    return calls


# -- Host: DNS rebinding ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("host", ["evil.example", "evil.example:8080", "127.0.0.1.evil.example", "", "a b"])
def test_rebinding_host_names_are_refused(server: RunningServer, host: str) -> None:
    headers = {"Host": host, **server.auth}
    for method, path, body in [("GET", "/api/robots", None), ("GET", "/api/robots/robot1/params", None),
                               ("POST", "/api/robots/robot1/teleop", {"x": 0.3}), ("GET", "/", None)]:
        reply = httpx.request(method, server.url + path, headers=headers, json=body, timeout=10)
        assert reply.status_code in (400, 421), (host, path, reply.status_code, reply.text)
    with pytest.raises(InvalidStatus) as refused:
        ws_client.connect(server.ws_url, additional_headers={"Host": host}, open_timeout=10)
    assert refused.value.response.status_code in (400, 403, 421)


def test_loopback_names_are_served(server: RunningServer) -> None:
    for host in ("127.0.0.1", f"127.0.0.1:{server.port}", f"localhost:{server.port}", f"[::1]:{server.port}"):
        assert httpx.get(f"{server.url}/api/robots", headers={"Host": host}, timeout=10).status_code == 200, host


def test_this_machines_address_only_when_listening_beyond_loopback(tmp_path: Path) -> None:
    outside = sorted(a for a in machine_addresses() if not a.startswith(("127.", "::1", "fe80")) and ":" not in a)
    if not outside:
        pytest.skip("this machine has no non-loopback IPv4 address")
    with dashboard_server(["--no-live", "--no-telemetry"], tmp_path) as local:
        assert httpx.get(f"{local.url}/api/robots", headers={"Host": outside[0]}, timeout=10).status_code == 421
    with dashboard_server(["--no-live", "--no-telemetry", "--allow-host", "laptop.team"], tmp_path,
                          host="0.0.0.0") as wide:
        for host in (outside[0], f"{outside[0]}:{wide.port}", "laptop.team"):
            reply = httpx.get(f"{wide.url}/api/robots", headers={"Host": host, **wide.auth}, timeout=10)
            assert reply.status_code == 200, (host, reply.text)
        assert httpx.get(f"{wide.url}/api/robots", headers={"Host": "evil.example"}, timeout=10).status_code == 421


# -- Origin: foreign pages ------------------------------------------------------------------------------------------
def test_websocket_from_a_foreign_page_is_refused(server: RunningServer) -> None:
    for origin in (EVIL, "null", f"http://127.0.0.1:{server.port + 1}", f"https://127.0.0.1:{server.port}"):
        with pytest.raises(InvalidStatus) as refused:
            ws_client.connect(server.ws_url, origin=origin, open_timeout=10)  # type: ignore[arg-type]
        assert refused.value.response.status_code == 403, origin
    # the dashboard's own page, and a client that is no browser (no Origin), are served
    for origin in (f"http://127.0.0.1:{server.port}", None):
        with ws_client.connect(server.ws_url, origin=origin, open_timeout=10) as ws:  # type: ignore[arg-type]
            assert json.loads(ws.recv(timeout=10))["type"] == "hello"


def test_every_control_endpoint_refuses_a_foreign_origin_even_with_the_credential(server: RunningServer) -> None:
    for method, path, body in unsafe_calls(server):
        for headers in ({"Origin": EVIL}, {"Origin": "null"}, {"Sec-Fetch-Site": "cross-site"}):
            reply = server.http.request(method, server.url + path, json=body, headers=headers, timeout=10)
            assert reply.status_code == 403, (method, path, headers, reply.text)
            assert "refused" in reply.json()["detail"]


@pytest.mark.parametrize("path", ["/api/robots/robot1/animation-stop", "/api/recordings/stop", "/api/replay/close",
                                  "/api/robots/robot1/teleop/stop", "/api/replay/play"])
def test_body_less_cross_site_posts_are_refused(server: RunningServer, path: str) -> None:
    """The form a foreign page can send without CORS: a POST with no body (or text/plain) from another site."""
    for headers in ({"Origin": EVIL}, {"Origin": EVIL, "Content-Type": "text/plain"}):
        assert httpx.post(server.url + path, headers=headers, timeout=10).status_code == 403, headers
    assert httpx.post(server.url + path, timeout=10).status_code == 401  # no Origin (a script): the credential


def test_reading_data_from_a_foreign_page_is_refused(server: RunningServer) -> None:
    for path in ("/api/robots", "/api/config", "/api/recordings", "/openapi.json"):
        assert httpx.get(server.url + path, headers={"Origin": EVIL}, timeout=10).status_code == 403, path
        no_cors = {"Sec-Fetch-Site": "cross-site", "Sec-Fetch-Mode": "no-cors"}  # <script src=...>, <img src=...>
        assert httpx.get(server.url + path, headers=no_cors, timeout=10).status_code == 403, path
    # the page itself may be linked from anywhere (it holds no data)
    page = httpx.get(server.url + "/", headers={"Sec-Fetch-Site": "cross-site", "Sec-Fetch-Mode": "navigate"})
    assert page.status_code == 200 and "pitchside" in page.text


def test_allowed_origin_by_flag(tmp_path: Path) -> None:
    args = ["--no-live", "--no-telemetry", "--allow-origin", "http://laptop2.team:8080"]
    with dashboard_server(args, tmp_path) as server:
        ok = server.http.post(f"{server.url}/api/replay/close", headers={"Origin": "http://laptop2.team:8080"})
        assert ok.status_code == 200, ok.text
        other = server.http.post(f"{server.url}/api/replay/close", headers={"Origin": "http://laptop3.team:8080"})
        assert other.status_code == 403


# -- the credential, also on loopback ------------------------------------------------------------------------------
def test_control_needs_the_credential_on_loopback(server: RunningServer) -> None:
    for method, path, body in unsafe_calls(server):
        for headers in ({}, {"Authorization": "Bearer wrong"}, {"Cookie": f"pitchside_session_{server.port}=x"}):
            reply = httpx.request(method, server.url + path, json=body, headers=headers, timeout=10)
            assert reply.status_code == 401, (method, path, headers, reply.text)
        # the old query parameter is no credential for the API (it would end up in logs and histories)
        reply = httpx.request(method, server.url + path, params={"token": server.token}, json=body, timeout=10)
        assert reply.status_code == 401, (method, path)
    # GETs that query robots are control too
    assert httpx.get(f"{server.url}/api/robots/robot1/params", timeout=10).status_code == 401


def test_the_printed_link_signs_the_browser_in_with_a_strict_http_only_cookie(server: RunningServer) -> None:
    with httpx.Client(base_url=server.url, timeout=10) as browser:
        assert browser.get("/api/config").json()["control"] is False
        refused = browser.get("/?token=wrong", follow_redirects=False)
        assert refused.status_code == 401 and not browser.cookies
        signed = browser.get(f"/?token={server.token}&panel=hcm", follow_redirects=False)
        assert signed.status_code == 303 and signed.headers["location"] == "/?panel=hcm"  # token dropped
        cookie = signed.headers["set-cookie"]
        assert "HttpOnly" in cookie and "SameSite=Strict" in cookie and server.token not in cookie
        assert browser.get("/api/config").json()["control"] is True
        assert browser.post("/api/replay/close").status_code == 200
        browser.delete("/api/session")
        assert browser.post("/api/replay/close").status_code == 401
        assert browser.post("/api/session", json={"token": "nope"}).status_code == 401
        assert browser.post("/api/session", json={"token": server.token}).status_code == 200
        assert browser.post("/api/replay/close").status_code == 200


def test_reading_needs_the_credential_beyond_loopback(tmp_path: Path) -> None:
    with dashboard_server(["--no-live", "--no-telemetry"], tmp_path, host="0.0.0.0") as server:
        for path in ("/api/robots", "/api/hub", "/api/recordings", "/openapi.json"):
            assert httpx.get(server.url + path, timeout=10).status_code == 401, path
            assert server.http.get(server.url + path).status_code == 200, path
        with pytest.raises(InvalidStatus) as refused:
            ws_client.connect(server.ws_url, open_timeout=10)
        assert refused.value.response.status_code == 401
        with ws_client.connect(server.ws_url, additional_headers=server.auth, open_timeout=10) as ws:
            assert json.loads(ws.recv(timeout=10))["type"] == "hello"
        assert httpx.get(server.url + "/api/config", timeout=10).json()["control"] is False  # the page's lock


def test_a_token_left_by_a_killed_server_is_not_used_and_goes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A killed server cannot remove its file: the command line must not send its stale token to whatever listens on
    the port now, and the next server sweeps it (a laptop at a competition starts hundreds)."""
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait(timeout=30)
    write_token_file(9001, "http://127.0.0.1:9001/", "alive-token")  # this process: running
    token_path(9002).write_text(json.dumps({"url": "http://127.0.0.1:9002/", "token": "stale", "pid": gone.pid}))
    assert read_token_file(9002) is None
    assert read_token_file(9001) == {"url": "http://127.0.0.1:9001/", "token": "alive-token", "pid": os.getpid()}
    write_token_file(9003, "http://127.0.0.1:9003/", "new-token")
    assert sorted(p.name for p in token_path(9001).parent.iterdir()) == ["server-9001.json", "server-9003.json"]


def test_the_command_line_finds_the_token_of_a_server_of_this_user(server: RunningServer) -> None:
    left = read_token_file(server.port)
    assert left is not None and left["token"] == server.token
    file = token_path(server.port)
    assert stat.S_IMODE(file.stat().st_mode) == 0o600 and stat.S_IMODE(file.parent.stat().st_mode) == 0o700
    env = {k: v for k, v in os.environ.items() if k != "PITCHSIDE_TOKEN"}
    for action in ("start", "stop"):  # POSTs: they need the credential, and the command finds it by itself
        done = subprocess.run([sys.executable, "-m", "pitchside.cli", "record", action, "cli-test", "--server",
                               server.url], cwd=REPO, env=env, capture_output=True, text=True, timeout=60)
        assert done.returncode == 0 and "cli-test" in done.stdout, done.stdout + done.stderr


# -- input limits ------------------------------------------------------------------------------------------------
def test_nested_and_huge_json_on_the_websocket_get_an_error_frame_and_the_connection_stays(
        server: RunningServer) -> None:
    with ws_client.connect(server.ws_url, open_timeout=10, max_size=None) as ws:
        assert json.loads(ws.recv(timeout=10))["type"] == "hello"
        bad_frames: list[str | bytes] = ["[" * 100_000, "{\"a\":" * 50_000, "[" * 33 + "]" * 33,
                                         json.dumps({"op": "ping", "id": "x" * 100_000}), b"\x00\xff" * 10,
                                         "\"" + "\\" * 5000, json.dumps({"op": "subscribe", "robot": "r" * 500})]
        for frame in bad_frames:
            ws.send(frame)
            reply = _next_of(ws, {"error"})
            assert reply["error"], frame[:40]
        ws.send(json.dumps({"op": "ping", "id": 7}))
        assert _next_of(ws, {"pong"})["id"] == 7


def _next_of(ws: Any, types: set[str]) -> dict[str, Any]:
    while True:
        raw = ws.recv(timeout=10)
        if isinstance(raw, str):
            frame = json.loads(raw)
            if frame["type"] in types:
                return dict(frame)


def test_nested_huge_and_binary_bodies_are_answered_not_crashed(server: RunningServer) -> None:
    url = f"{server.url}/api/replay/open"
    deep = server.http.post(url, content=b"[" * 100_000, headers={"Content-Type": "application/json"})
    assert deep.status_code == 400 and "deeper" in deep.json()["detail"]
    huge = server.http.post(url, content=b" " * (5 << 20), headers={"Content-Type": "application/json"})
    assert huge.status_code == 413
    binary = server.http.post(url, content=os.urandom(2000), headers={"Content-Type": "application/json"})
    assert binary.status_code in (400, 422), binary.text
    assert server.http.get(f"{server.url}/api/replay").status_code == 200  # still serving


def test_parameter_events_outlive_what_a_process_on_the_bus_sends(router_endpoint: str, client: zenoh.Session,
                                                                  tmp_path: Path) -> None:
    """The browser's stream of parameter events carries what nodes announce on /parameter_events. A sample that is
    no ParameterEvent, or comes without rmw_zenoh's attachment, is skipped; a value with a carriage return (which
    ends a line of a server-sent event) arrives as one line, as the server writes it; the stream stays open and
    the next event arrives."""
    import struct
    import time

    import schemas
    from schemas.codec import type_hash

    key = f"{keys.domain_id()}/parameter_events/rcl_interfaces::msg::dds_::ParameterEvent_/" + type_hash(
        "rcl_interfaces/msg/ParameterEvent")
    numbers = iter(range(1, 1_000_000))

    def event(name: str, text: str) -> bytes:
        value = schemas.make("rcl_interfaces/msg/ParameterValue", type=4, string_value=text)
        return schemas.encode(schemas.make(
            "rcl_interfaces/msg/ParameterEvent", node="/r6/hcm",
            changed_parameters=[schemas.make("rcl_interfaces/msg/Parameter", name=name, value=value)]))

    def stamped() -> bytes:  # rmw_zenoh's attachment: sequence number, time, GID
        return struct.pack("<qqB", next(numbers), time.time_ns(), 16) + bytes(16)

    good = {"node": "hcm", "changed": {"mode": "good"}}
    lines: list[str] = []
    closed = threading.Event()
    with dashboard_server(["--connect", router_endpoint, "--no-telemetry"], tmp_path) as server:
        def listen() -> None:
            try:
                with httpx.stream("GET", f"{server.url}/api/robots/r6/params/*/events", headers=server.auth,
                                  timeout=httpx.Timeout(10.0, read=None)) as reply:
                    assert reply.status_code == 200
                    for line in reply.iter_lines():
                        lines.append(line)
            except httpx.HTTPError:
                pass
            closed.set()

        reader = threading.Thread(target=listen, daemon=True)
        reader.start()
        wait_for(lambda: lines, 20.0, 0.05, "the event stream open")

        def delivered() -> bool:  # sent again until the server's subscription is routed to this session
            client.put(key, b"[" * 100_000, attachment=stamped())  # no ParameterEvent
            client.put(key, event("mode", "unattached"))  # rmw_zenoh drops it, so does the server
            client.put(key, event("mode", "a\rb\r\nc"), attachment=stamped())
            client.put(key, event("mode", "good"), attachment=stamped())
            return closed.is_set() or any(line.startswith("data: ") and json.loads(line[6:]) == good for line in lines)

        wait_for(delivered, 20.0, 0.2, "an event after the hostile ones")
        assert not closed.is_set(), lines
        data = [json.loads(line[6:]) for line in lines if line.startswith("data: ")]  # every one a whole event
        assert {"node": "hcm", "changed": {"mode": "a\rb\r\nc"}} in data
        assert not [d for d in data if d["changed"] == {"mode": "unattached"}]
        assert not [line for line in lines if line and not line.startswith(("data: ", ": "))], lines
    reader.join(10)


def test_a_failing_request_is_answered_with_the_security_headers(tmp_path: Path) -> None:
    """A bug that raises in an endpoint is answered by the guard (500, JSON, every security header), not by
    Starlette's own error page around it, which carries none of them."""
    port = free_port()
    config = ServerConfig(port=port, live_source=False, telemetry_source=False, recordings_dir=tmp_path)
    app = create_app(config)

    def broken() -> None:
        raise RuntimeError("a bug")

    app.router.routes.insert(0, APIRoute("/api/broken", broken))  # before the page's files, which take the rest
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="critical"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    try:
        wait_for(lambda: server.started, 30.0, 0.05, "the server up")
        reply = httpx.get(f"http://127.0.0.1:{port}/api/broken", timeout=10)
        assert reply.status_code == 500 and reply.headers["content-type"] == "application/json", reply.text
        assert reply.headers.get("x-content-type-options") == "nosniff"
        assert "frame-ancestors 'self'" in reply.headers.get("content-security-policy", "")
        assert "a bug" not in reply.text  # the details stay in the server's log
        assert httpx.get(f"http://127.0.0.1:{port}/api/config", timeout=10).status_code == 200  # still serving
    finally:
        server.should_exit = True
        thread.join(10)


# -- what the demo opens -------------------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("command", ["demo", "match"])
def test_the_demo_listens_on_loopback_only(tmp_path: Path, command: str) -> None:
    """Everything of `pitchside demo` (and of `pitchside match` with its simulated GameController) runs on this
    machine: none of its processes (world, robot nodes, simulated GameController, dashboard, 3D view, plots,
    Foxglove) takes a port a stranger on the network could send to, UDP included (the GameController receivers,
    bound to the loopback broadcast address in a match, the team communication, the telemetry listener, the
    telemetry sender's own socket)."""
    args = ("--robots", "1v1") if command == "match" else ()
    with running_demo(tmp_path, *args, command=command) as demo:
        def telemetry_flows() -> bool:
            sources = httpx.get(f"{demo.url}/api/sources", headers=demo.auth, timeout=10).json()
            return any(s["name"] == "telemetry" and s.get("messages", 0) > 0 for s in sources)

        wait_for(telemetry_flows, 120.0, 0.5, "the robot's telemetry at the dashboard")
        opened = []
        for process in demo.processes():
            try:
                connections = process.net_connections(kind="inet")
            except psutil.NoSuchProcess:
                continue
            opened += [(process.name(), " ".join(process.cmdline()[1:4]), c.type, c.laddr) for c in connections
                       if c.status == psutil.CONN_LISTEN or c.type == socket.SOCK_DGRAM]
        assert len(opened) >= 8, opened  # the dashboard, its views, every node's bus port, the UDP links
        assert {c[2] for c in opened} == {socket.SOCK_STREAM, socket.SOCK_DGRAM}, opened
        assert [c for c in opened if not is_loopback(c[3].ip)] == []


# -- paths and names from clients ----------------------------------------------------------------------------------
def test_replay_opens_only_inside_the_allowed_folders_and_does_not_tell_what_exists(
        server: RunningServer, tmp_path: Path) -> None:
    secret = tmp_path / "secret.mcap"
    secret.write_bytes(b"not for you")
    rec = Path(re.search(r"--recordings (\S+)", " ".join(server.process.args))[1])  # type: ignore[arg-type,index]
    (rec / "link.mcap").symlink_to(secret)
    answers = []
    for path in ("/etc/passwd", "/etc/nothing-here", str(secret), "../../etc/passwd", "link.mcap", "\0x"):
        reply = server.http.post(f"{server.url}/api/replay/open", json={"path": path})
        assert reply.status_code == 403, (path, reply.text)
        answers.append(reply.json()["detail"])
    assert len(set(answers[:3])) == 1, answers  # the same answer whether the file exists or not


@pytest.mark.parametrize("robot", ["*", "**", "a*b", "x<y", "a%2Fb", "r" * 13])
def test_robot_ids_in_urls_that_would_widen_a_zenoh_key_are_refused(server: RunningServer, robot: str) -> None:
    reply = server.http.get(f"{server.url}/api/robots/{robot}/params")
    assert reply.status_code in (404, 422), (robot, reply.text)


# -- headers ---------------------------------------------------------------------------------------------------------
def test_security_headers_on_every_page(server: RunningServer) -> None:
    for path in ("/", "/app.js", "/api/config", "/nothing-here"):
        reply = httpx.get(server.url + path, timeout=10)
        csp = reply.headers.get("content-security-policy", "")
        assert reply.headers.get("x-content-type-options") == "nosniff", path
        assert "frame-ancestors 'self'" in csp and "script-src 'self'" in csp and "unsafe-inline" not in \
            csp.split("script-src", 1)[1].split(";", 1)[0], (path, csp)
    assert httpx.get(server.url + "/docs", timeout=10).status_code == 404  # FastAPI's docs load from a CDN


# -- match mode and the telemetry key -------------------------------------------------------------------------------
def test_match_mode_refuses_the_development_key_unless_told(tmp_path: Path) -> None:
    port = free_port()
    done = subprocess.run([sys.executable, "-m", "server", "--match", "--port", str(port), "--no-telemetry"],
                          cwd=REPO, capture_output=True, text=True, timeout=60)
    assert done.returncode != 0 and "telemetry key" in done.stderr + done.stdout
    key = tmp_path / "team.key"
    made = subprocess.run([sys.executable, "-m", "pitchside.cli", "telemetry-key", str(key)], cwd=REPO,
                          capture_output=True, text=True, timeout=60)
    assert made.returncode == 0 and stat.S_IMODE(key.stat().st_mode) == 0o600
    fingerprint = re.search(r"fingerprint ([0-9a-f]{8})", made.stdout)
    assert fingerprint, made.stdout
    again = subprocess.run([sys.executable, "-m", "pitchside.cli", "telemetry-key", str(key)], cwd=REPO,
                           capture_output=True, text=True, timeout=60)
    assert again.returncode != 0 and "exists" in again.stderr  # a team keeps its key
    with dashboard_server(["--match", "--telemetry-key", str(key), "--telemetry-port", str(free_port())],
                          tmp_path) as match:
        assert httpx.get(f"{match.url}/api/config").json()["telemetry_key"] == fingerprint[1]
        assert f"team {fingerprint[1]}" in match.output()
    with dashboard_server(["--match", "--allow-dev-key", "--telemetry-port", str(free_port())], tmp_path) as dev:
        assert httpx.get(f"{dev.url}/api/config").json()["telemetry_key"] == "development"
        assert "development key" in dev.output()


def test_names_from_the_bus_that_break_the_rules_never_reach_the_hub(router_endpoint: str, client: Any,
                                                                      tmp_path: Path) -> None:
    import schemas
    from wire.keys import topic_key

    state = schemas.encode(schemas.make("humanoid_league_msgs/msg/RobotControlState", state=2))
    with dashboard_server(["--connect", router_endpoint, "--no-telemetry"], tmp_path) as server:
        def live() -> dict[str, Any]:
            return next(s for s in server.http.get(f"{server.url}/api/sources").json() if s["name"] == "live")

        def heard() -> bool:
            for robot in ("<script>x</script>", "robot_with_a_long_id", "r1\"x"):  # on the bus, not via topic_key
                client.put(topic_key("*", "robot_state").replace("/*/", f"/{robot}/", 1), state)
            client.put(topic_key("r1", "robot_state"), state)
            return live()["bad_names"] >= 3 and any(r["robot"] == "r1" for r in
                                                    server.http.get(f"{server.url}/api/robots").json())

        wait_for(heard, 20.0, 0.2, "the live source heard good and bad names")
        robots = {r["robot"] for r in server.http.get(f"{server.url}/api/robots").json()}
        assert robots == {"r1"}, robots
