"""Foxglove and Lichtblick as people run them (issue 46): the apps' own ways of connecting, through the real client.

Each app is the real @foxglove/ws-protocol client (tests/foxglove_client) connecting as that app does: the Origin it
sends (the desktop apps load their window from file://, so Electron sends ``Origin: file://``; a web app sends the
origin it was loaded from) and the subprotocols it offers (Lichtblick before its pull request #819 and every
foxglove_bridge-era client offer only ``foxglove.websocket.v1``; newer ones offer ``foxglove.sdk.v1`` too). One server
on loopback with a robot of real nodes (parameters, the pause node's manual_penalize, the animation node) serves the
same-machine cases; one on every interface with ``--foxglove-tls`` (a certificate from the team's CA) reached at the
machine's own address stands for another machine.
"""

from __future__ import annotations

import asyncio
import contextlib
import ipaddress
import json
import socket
import ssl
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import pytest
from cryptography import x509

from pitchside.team_keys import create_team
from pitchside.team_keys import main as team_keys
from robot_nodes.animation.node import AnimationNode
from robot_nodes.hcm.pause import PauseNode
from robot_nodes.runtime import BusConfig, Node, open_router, open_session
from server.foxglove import subprotocols
from server.foxglove.guard import GuardPolicy, Refused
from server.foxglove.subprotocols import pass_to_websocket_v1, request_for_sdk, response_for_client
from server.foxglove.tls import TlsError, server_context
from server.foxglove_layout import layout_topics
from server.security.credentials import Credentials
from server.security.hosts import AllowedHosts
from tests.dashboard_server import RunningServer, dashboard_server
from tests.foxglove_node import foxglove_url, run_client
from tests.foxglove_stand import PoseStand
from tests.support import free_port
from tests.test_foxglove_control import TWIST, CmdVel
from tests.waiting import wait_for
from wire.machine import machine_addresses

ROBOT = "r1"
SDK, V1 = "foxglove.sdk.v1", "foxglove.websocket.v1"
DESKTOP = "file://"
CONTROL = {"parameters", "services", "clientPublish"}
# how each app connects, as the tests emulate it: (Origin, subprotocols offered)
APPS = {
    "Lichtblick desktop": (DESKTOP, [SDK, V1]),
    "Lichtblick desktop before 2026": (DESKTOP, [V1]),
    "Foxglove desktop": (DESKTOP, [SDK, V1]),
    "Lichtblick self-hosted on this laptop": ("http://localhost:8080", [SDK, V1]),
    "Lichtblick self-hosted, older, on this laptop": ("http://127.0.0.1:3000", [V1]),
    "Foxglove web (app.foxglove.dev)": ("https://app.foxglove.dev", [SDK, V1]),
}


@dataclass
class Lab:
    server: RunningServer
    url: str
    stand: PoseStand
    cmd_vel: CmdVel
    paused: list[bool]


@pytest.fixture(scope="module")
def lab(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Lab]:
    """The dashboard on loopback with its Foxglove endpoint, and one robot of real nodes on the server's bus."""
    import schemas
    from wire.keys import topic_key

    folder = tmp_path_factory.mktemp("apps")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = open_router([endpoint])
    session = open_session(BusConfig(connect=[endpoint]))
    stand = PoseStand(ROBOT, session)
    nodes: list[Node] = [stand.start(), PauseNode(ROBOT, session).start(), AnimationNode(ROBOT, session).start()]
    watcher = open_session(BusConfig(connect=[endpoint]))  # another process's view: what reaches the bus
    paused: list[bool] = []
    listener = watcher.declare_subscriber(topic_key(ROBOT, "paused"), lambda s: paused.append(
        schemas.decode(s.payload.to_bytes(), "std_msgs/msg/Bool").data))
    try:
        with dashboard_server(["--connect", endpoint, "--no-telemetry", "--foxglove-port", str(free_port())],
                              folder) as server:
            url = wait_for(lambda: foxglove_url(server.output()), timeout=30, what="the foxglove banner")
            assert url is not None and url.startswith("ws://127.0.0.1:")
            wait_for(lambda: any(r["robot"] == ROBOT for r in server.http.get(f"{server.url}/api/robots").json()),
                     timeout=30, interval=0.2, what="r1 heard")
            yield Lab(server, url, stand, CmdVel(watcher), paused)
    finally:
        listener.undeclare()
        for node in nodes:
            node.shutdown()
        session.close()
        watcher.close()
        router.close()


def hello(url: str, origin: str | None = None, offers: tuple[str, ...] = (SDK,), *extra: str) -> dict[str, Any]:
    """What an app sees when it connects: subprotocol, serverInfo and channels, or the refusal."""
    args = [a for p in offers for a in ("--subprotocol", p)] + (["--origin", origin] if origin else [])
    return run_client("hello", url, *args, "--seconds", "10", *extra)


def test_both_subprotocols_alone_or_together_get_the_one_they_offered(lab: Lab) -> None:
    for offered, answered in (([SDK], SDK), ([V1], V1), ([SDK, V1], SDK), ([V1, SDK], SDK)):
        got = hello(lab.url, None, tuple(offered), "--min", "1")
        assert got.get("subprotocol") == answered, (offered, got)
        assert got["serverInfo"]["name"] == "pitchside" and got["errors"] == [] and got["channels"], got
    refused = hello(lab.url, None, ("foxglove.websocket.v2",))
    assert refused["refused"] == 400 and V1 in refused["reason"] and SDK in refused["reason"], refused
    # what the SDK sends is what a foxglove.websocket.v1 client reads: every message decoded, no error
    got = run_client("probe", lab.url, "--subprotocol", V1, "--topic", f"/{ROBOT}/joint_states", "--topic",
                     f"/{ROBOT}/tf", "--min", "3", "--seconds", "20")
    assert got["subprotocol"] == V1
    for topic in (f"/{ROBOT}/joint_states", f"/{ROBOT}/tf"):
        seen = got["topics"][topic]
        assert seen["count"] >= 3 and seen["errors"] == [], (topic, seen)
    assert len(got["topics"][f"/{ROBOT}/joint_states"]["last"]["name"]) == 20  # the minibot's joints
    status = lab.server.http.get(f"{lab.server.url}/api/foxglove").json()
    assert status["websocket_v1"] >= 2 and status["refused"].get("400", 0) >= 1, status


def test_the_desktop_apps_and_pages_of_this_machine_watch_without_the_token_and_no_other_page_does(lab: Lab) -> None:
    for app, (origin, offered) in APPS.items():
        got = hello(lab.url, origin, tuple(offered))
        if origin.startswith("https://app.foxglove.dev"):
            assert got.get("refused") == 403 and "token" in got["reason"], (app, got)
        else:
            assert got.get("subprotocol") == offered[0] and not CONTROL & set(got["serverInfo"]["capabilities"]), \
                (app, got)
        with_token = hello(f"{lab.url}/?token={lab.server.token}", origin, tuple(offered))
        assert set(with_token["serverInfo"]["capabilities"]) >= CONTROL, (app, with_token)
    for origin in ("null", "https://evil.example", "http://192.0.2.7:8080", "file:///home/me/page.html"):
        assert hello(lab.url, origin).get("refused") == 403, origin
        assert set(hello(f"{lab.url}/?token={lab.server.token}", origin)["serverInfo"]["capabilities"]) >= CONTROL
    assert hello(lab.url)["serverInfo"]["name"] == "pitchside"  # a script or ROS tool: no Origin at all
    assert hello(f"{lab.url}/?token=guess", DESKTOP).get("refused") == 401


def test_changing_a_robot_needs_the_token_whatever_the_origin(lab: Lab) -> None:
    """Parameters, services and publishing: refused without the token to the desktop apps and to pages of this
    machine, done with it (here by an app that offers only foxglove.websocket.v1)."""
    drive = {"linear": {"x": 0.3, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}
    attempts = [{"op": "setParameters", "parameters": [{"name": f"/{ROBOT}/posestand/x", "value": 2.5,
                                                        "type": "float64"}], "noAnswer": True},
                {"op": "publish", "topic": f"/{ROBOT}/cmd_vel", "encoding": "json", "schemaName": TWIST,
                 "message": drive, "hz": 10, "count": 3},
                {"op": "wait", "ms": 500}]
    for origin in (DESKTOP, "http://localhost:8080"):
        got = run_client("session", lab.url, "--origin", origin, "--script", json.dumps(attempts), "--seconds", "5")
        assert got["errors"] == [] and not CONTROL & set(got["serverInfo"]["capabilities"]), (origin, got)
        assert got["services"] == []  # nothing to call
        refused = " ".join(s["message"] for s in got["statuses"])
        assert "does not support parameters" in refused and "clientPublish" in refused, (origin, got["statuses"])
    assert lab.stand.params.x == 1.0 and not lab.cmd_vel.got and True not in lab.paused
    steps = [{"op": "waitService", "service": f"/{ROBOT}/manual_penalize"},
             {"op": "callService", "service": f"/{ROBOT}/manual_penalize", "request": {"penalize": 1}},
             {"op": "setParameters", "parameters": [{"name": f"/{ROBOT}/posestand/x", "value": 2.5,
                                                     "type": "float64"}]},
             {"op": "publish", "topic": f"/{ROBOT}/cmd_vel", "encoding": "json", "schemaName": TWIST,
              "message": drive, "hz": 10, "count": 3},
             {"op": "callService", "service": f"/{ROBOT}/manual_penalize", "request": {"penalize": 0}}]
    control_url = f"{lab.url}/?token={lab.server.token}"  # the URL the server prints for control
    assert f"to control (parameters, services, cmd_vel): {control_url} " in lab.server.output()
    got = run_client("session", control_url, "--origin", DESKTOP, "--subprotocol", V1,
                     "--script", json.dumps(steps), "--seconds", "20", timeout=60)
    assert got["errors"] == [] and got["subprotocol"] == V1, got
    on = next(r["response"] for r in got["results"] if r["op"] == "callService")
    assert on == {"penalized": True} and wait_for(lambda: True in lab.paused, timeout=10, what="paused")
    assert lab.stand.params.x == 2.5
    assert any(g[1:] == pytest.approx((0.3, 0.0, 0.0)) for g in lab.cmd_vel.got), lab.cmd_vel.got


@contextlib.contextmanager
def tunnel(to_port: int) -> Iterator[int]:
    """What `ssh -L PORT:127.0.0.1:8765 laptop` is at the laptop's end: connections from loopback, to loopback,
    the app's own Host (its local port) and Origin passed as they came. Yields the port the app connects to."""
    listening = socket.create_server(("127.0.0.1", 0))
    stop = threading.Event()
    opened: list[socket.socket] = []

    def copy(source: socket.socket, target: socket.socket) -> None:
        with contextlib.suppress(OSError):
            while chunk := source.recv(65536):
                target.sendall(chunk)
        with contextlib.suppress(OSError):
            target.shutdown(socket.SHUT_WR)

    def accept() -> None:
        while not stop.is_set():
            try:
                app, _ = listening.accept()
            except OSError:
                return
            laptop = socket.create_connection(("127.0.0.1", to_port))
            opened.extend((app, laptop))
            for pair in ((app, laptop), (laptop, app)):
                threading.Thread(target=copy, args=pair, daemon=True).start()

    acceptor = threading.Thread(target=accept, daemon=True)
    acceptor.start()
    try:
        yield int(listening.getsockname()[1])
    finally:
        stop.set()
        listening.close()
        acceptor.join(5)
        for sock in opened:
            sock.close()


def test_through_an_ssh_tunnel_a_laptop_without_the_team_ca_connects_as_on_the_laptop_itself(lab: Lab) -> None:
    """A team without a CA: the other laptop forwards a local port to the team laptop's endpoint, which stays on
    loopback. Its desktop app watches without the token; a browser app (an https page may open ws:// to
    127.0.0.1) needs the token, as on the laptop itself."""
    port = int(lab.url.rsplit(":", 1)[1])
    with tunnel(port) as local:
        here = f"ws://127.0.0.1:{local}"
        desktop = hello(here, DESKTOP, (SDK, V1), "--min", "1")
        assert desktop.get("subprotocol") == SDK and f"/{ROBOT}/joint_states" in desktop["channels"], desktop
        assert hello(here, "https://app.foxglove.dev").get("refused") == 403
        web = hello(f"{here}/?token={lab.server.token}", "https://app.foxglove.dev", (SDK, V1))
        assert set(web["serverInfo"]["capabilities"]) >= CONTROL, web


def test_the_layout_names_only_panels_it_configures_and_downloads_read_only(lab: Lab) -> None:
    server = lab.server
    response = httpx.get(f"{server.url}/api/foxglove/layout", params={"robot": ROBOT})  # no token: on loopback
    assert response.status_code == 200 and response.headers["content-type"] == "application/json"
    assert 'filename="pitchside-r1.json"' in response.headers["content-disposition"]
    layout = response.json()
    assert {"configById", "globalVariables", "userNodes", "playbackConfig", "layout"} <= set(layout)

    def leaves(node: Any) -> list[str]:
        return [node] if isinstance(node, str) else leaves(node["first"]) + leaves(node["second"])

    panels = leaves(layout["layout"])
    assert sorted(panels) == sorted(layout["configById"])  # every panel placed, every placed panel configured
    kinds = {p.split("!")[0] for p in panels}
    assert kinds == {"3D", "Image", "Plot", "StateTransitions", "DiagnosticSummary", "RosOut"}
    topics = layout_topics(layout)
    assert topics and all(t.startswith(f"/{ROBOT}/") for t in topics), topics
    assert {f"/{ROBOT}/robot_description", f"/{ROBOT}/camera/annotations", f"/{ROBOT}/imu/data",
            f"/{ROBOT}/robot_state", f"/{ROBOT}/diagnostics", f"/{ROBOT}/rosout"} <= topics
    # the same checks as every other /api/ path
    assert httpx.get(f"{server.url}/api/foxglove/layout", headers={"Host": "evil.example"}).status_code == 421
    assert httpx.get(f"{server.url}/api/foxglove/layout",
                     headers={"Origin": "https://evil.example"}).status_code == 403
    assert httpx.get(f"{server.url}/api/foxglove/layout", params={"robot": "r1/../x"}).status_code == 422
    assert server.http.post(f"{server.url}/api/foxglove/layout").status_code == 405


@pytest.fixture(scope="module")
def team(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A team made by `pitchside team-keys`, with the laptop's web certificate for its own address."""
    folder = tmp_path_factory.mktemp("team") / "team"
    create_team(folder, "Testers", ["robot1"])
    return folder


def other_address() -> str:
    """This machine's address as another machine reaches it (not loopback)."""
    found = sorted(a for a in machine_addresses() if ":" not in a and not ipaddress.ip_address(a).is_loopback)
    if not found:
        pytest.skip("this machine has no IPv4 address beyond loopback")
    return found[0]


def test_team_keys_makes_a_web_certificate_browsers_accept(team: Path, capsys: pytest.CaptureFixture[str]) -> None:
    address = other_address()
    team_keys([str(team), "--web-names", f"laptop.local,{address}"])
    assert "pitchside serve --foxglove-tls" in capsys.readouterr().out
    chain = x509.load_pem_x509_certificates((team / "web.pem").read_bytes())
    leaf, ca = chain
    assert ca.subject == x509.load_pem_x509_certificate((team / "team-ca.pem").read_bytes()).subject
    names = leaf.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert set(names.get_values_for_type(x509.DNSName)) == {"laptop.local", "localhost"}
    assert {str(a) for a in names.get_values_for_type(x509.IPAddress)} == {address, "127.0.0.1", "::1"}
    assert (leaf.not_valid_after_utc - leaf.not_valid_before_utc).days <= 398  # browsers' limit
    assert (team / "web.key").stat().st_mode & 0o077 == 0
    # the folder, or the pair given: both load; a folder without a web certificate says how to make one
    server_context(team)
    server_context(team / "web.pem", team / "web.key")
    with pytest.raises(TlsError, match="--web-names"):
        server_context(team.parent)
    with pytest.raises(TlsError, match="not a PEM certificate"):
        server_context(team / "team.json", team / "web.key")
    context = ssl.create_default_context(cafile=team / "team-ca.pem")  # the chain verifies against the team CA
    assert context.get_ca_certs()


def test_a_new_team_can_have_its_web_certificate_at_once_and_a_new_ca_drops_the_old_one(tmp_path: Path) -> None:
    folder = tmp_path / "team"
    team_keys([str(folder), "--team", "Testers", "--robots", "robot1", "--web-names", "laptop.local"])
    first = x509.load_pem_x509_certificates((folder / "web.pem").read_bytes())
    assert first[1].subject == x509.load_pem_x509_certificate((folder / "team-ca.pem").read_bytes()).subject
    team_keys([str(folder), "--team", "Testers", "--robots", "robot1", "--force"])  # a new CA, no web names
    assert not (folder / "web.pem").exists() and not (folder / "web.key").exists()
    with pytest.raises(SystemExit):  # names are host names or addresses
        team_keys([str(folder), "--web-names", "bad name"])


def test_another_machine_connects_over_wss_with_the_token_and_the_team_ca(team: Path, tmp_path: Path) -> None:
    address = other_address()
    if not (team / "web.pem").exists():
        team_keys([str(team), "--web-names", address])
    with dashboard_server(["--no-live", "--no-telemetry", "--foxglove-port", str(free_port()), "--foxglove-tls",
                           str(team / "web.pem"), "--foxglove-tls-key", str(team / "web.key")], tmp_path,
                          host="0.0.0.0") as server:
        urls = wait_for(lambda: foxglove_url(server.output()), timeout=30, what="the foxglove banner")
        assert urls is not None and urls.startswith("wss://127.0.0.1:") and urls.endswith(f"?token={server.token}")
        port = int(urls.split(":")[2].split("/")[0])
        there = f"wss://{address}:{port}"
        assert f"{there}/?token={server.token}" in server.output()  # the URL for other machines, printed
        ca = ["--ca", str(team / "team-ca.pem")]
        # Foxglove web on another laptop that trusts the team CA, with the token: it connects and may control
        got = hello(f"{there}/?token={server.token}", "https://app.foxglove.dev", (SDK, V1), *ca)
        assert got.get("subprotocol") == SDK and got["serverInfo"]["name"] == "pitchside", got
        assert set(got["serverInfo"]["capabilities"]) >= CONTROL
        old = hello(f"{there}/?token={server.token}", DESKTOP, (V1,), *ca)
        assert old.get("subprotocol") == V1 and set(old["serverInfo"]["capabilities"]) >= CONTROL, old
        # without the token nobody beyond loopback, not even a desktop app
        for origin in (DESKTOP, "http://localhost:8080", None):
            assert hello(there, origin, (SDK,), *ca).get("refused") == 401, origin
        # a laptop that does not trust the team CA: the TLS handshake fails, nothing is sent
        untrusted = hello(f"{there}/?token={server.token}", "https://app.foxglove.dev", (SDK,))
        assert untrusted.get("code") in ("SELF_SIGNED_CERT_IN_CHAIN", "UNABLE_TO_VERIFY_LEAF_SIGNATURE",
                                         "UNABLE_TO_GET_ISSUER_CERT_LOCALLY"), untrusted
        # plain ws:// to the wss:// port: no handshake either
        assert "error" in hello(f"ws://{address}:{port}/?token={server.token}")
        assert server.http.get(f"{server.url}/api/foxglove").json()["tls"] is True


def test_the_guard_trusts_the_desktop_apps_and_this_machines_pages_to_watch_never_null_or_beyond_loopback() -> None:
    policy = GuardPolicy(AllowedHosts("127.0.0.1"), Credentials("s3cret", 8080),
                         allowed_origins=frozenset({"http://laptop2:8080"}))

    def status(origin: str | None, target: str = "/") -> int:
        headers = {"host": "127.0.0.1:8765", **({"origin": origin} if origin is not None else {})}
        try:
            return 200 + 1 * policy.check(target.encode(), headers)  # 201: with the token (control)
        except Refused as refused:
            return refused.status

    watching = [None, "file://", "FILE://", "http://localhost:8080", "http://localhost", "http://127.0.0.1:3000",
                "https://127.0.0.1", "http://[::1]:8080", "http://127.0.0.2:80", "http://laptop2:8080"]
    refused = ["null", "https://evil.example", "http://localhost.evil.example", "http://127.0.0.1.nip.io",
               "file:///tmp/x.html", "http://192.0.2.2:8080", "chrome-extension://abc", ""]
    assert [status(o) for o in watching] == [200] * len(watching)
    assert [status(o) for o in refused] == [403] * len(refused)
    assert [status(o, "/?token=s3cret") for o in watching + refused] == [201] * (len(watching) + len(refused))
    policy.token_needed = True  # beyond loopback: the token, whoever asks
    assert [status(o) for o in watching + refused] == [401] * (len(watching) + len(refused))
    assert status("file://", "/?token=s3cret") == 201


def test_foxglove_help_says_which_origins_are_trusted_for_what() -> None:
    from server.__main__ import arguments

    text = " ".join(arguments().format_help().split())
    for words in ("foxglove.websocket.v1", "Origin file://", "http://localhost:*", "Origin null",
                  "?token=<token>", "only to watch", "--foxglove-tls"):
        assert words in text, words


def test_the_request_and_answer_name_the_subprotocol_each_side_knows() -> None:
    request = (b"GET /?token=x HTTP/1.1\r\nHost: 127.0.0.1:8765\r\nSec-WebSocket-Protocol: foxglove.websocket.v1\r\n"
               b"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nsec-websocket-protocol: other\r\n\r\n")
    rewritten = request_for_sdk(request)
    assert rewritten.count(b"Sec-WebSocket-Protocol") == 1 and b"other" not in rewritten
    assert b"Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n" in rewritten and rewritten.endswith(b"\r\n\r\n")
    assert b"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n" in rewritten  # the SDK's accept key stays right
    assert subprotocols.offered([(b"Sec-WebSocket-Protocol", b"a, foxglove.websocket.v1"), (b"host", b"x"),
                    (b"sec-websocket-protocol", b"foxglove.sdk.v1")]) == ["a", V1, SDK]
    answer = (b"HTTP/1.1 101 Switching Protocols\r\nconnection: Upgrade\r\nupgrade: websocket\r\n"
              b"sec-websocket-protocol: foxglove.sdk.v1\r\nsec-websocket-accept: s3pPLMBiTxaQ9kYGzzhZRbK+xOo=\r\n\r\n")
    assert response_for_client(answer) == answer.replace(SDK.encode(), V1.encode())


def test_a_websocket_v1_client_gets_every_frame_but_the_sdks_playback_state() -> None:
    """Frames as the SDK writes them (RFC 6455, unmasked, each length form) through the guard's copy for a
    foxglove.websocket.v1 client, read back with the websockets library's own frame parser."""
    from websockets.frames import Frame, Opcode
    from websockets.streams import StreamReader

    answer = b"HTTP/1.1 101 Switching Protocols\r\nsec-websocket-protocol: foxglove.sdk.v1\r\n\r\n"
    kept = [Frame(Opcode.TEXT, b'{"op":"serverInfo"}'), Frame(Opcode.BINARY, b"\x01" + bytes(100)),
            Frame(Opcode.BINARY, b"\x01" + bytes(70_000)),  # 64-bit length
            Frame(Opcode.BINARY, b"\x02" + bytes(8)), Frame(Opcode.BINARY, b"\x04" + bytes(300)),  # 16-bit length
            Frame(Opcode.PING, b""), Frame(Opcode.TEXT, b"\x05 text, not the binary opcode")]
    playback = [Frame(Opcode.BINARY, b"\x05" + bytes(30)), Frame(Opcode.BINARY, b"\x05" + bytes(200))]
    sent = [kept[0], playback[0], *kept[1:4], playback[1], *kept[4:], Frame(Opcode.CLOSE, b"\x03\xe8")]

    async def through_the_guard() -> tuple[bytes, int]:
        reader = asyncio.StreamReader()
        reader.feed_data(answer + b"".join(f.serialize(mask=False) for f in sent))
        reader.feed_eof()
        ours, theirs = socket.socketpair()
        _, writer = await asyncio.open_connection(sock=ours)
        client, _ = await asyncio.open_connection(sock=theirs)
        received = asyncio.create_task(client.read(-1))
        dropped = await pass_to_websocket_v1(reader, writer)
        writer.close()
        return await received, dropped

    out, dropped = asyncio.run(through_the_guard())
    assert dropped == 2
    head, _, frames = out.partition(b"\r\n\r\n")
    assert head.endswith(b"sec-websocket-protocol: foxglove.websocket.v1")
    parser = StreamReader()
    parser.feed_data(frames)
    parser.feed_eof()
    parsed = []
    while True:
        try:
            next(Frame.parse(parser.read_exact, mask=False))
            raise AssertionError("a frame cut short")
        except StopIteration as done:
            parsed.append(done.value)
        except EOFError:
            break
    assert [(f.opcode, bytes(f.data)) for f in parsed] == [(f.opcode, f.data) for f in [*kept, sent[-1]]]
