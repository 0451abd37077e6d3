"""A team's secured bus across machines: the team laptop and robot1 are separate computers (Linux network
namespaces, tests.netlab), each with its own Zenoh router, linked router to router over mutual TLS.

The laptop runs `pitchside router --zenoh-config router.json5` and a member session with laptop.json5 (the file
the dashboard takes); robot1 runs `pitchside launch --zenoh-config robot1.json5 tests.teststand` (the robot's
router from its file, the node a plain peer of it on loopback) and a probe among its nodes that reports what
reaches robot1's control topics. An outsider on a third machine, and one on the laptop without certificates,
try to get onto the bus and to send robot1 motor goals. Processes in the namespaces report through their logs
(one JSON line per event), which the test reads.

    python -m tests.test_bus_security_machines probe [--zenoh-config FILE] [--subscribe ROBOT/TOPIC ...]
                                                     [--put ROBOT/TOPIC=SENDER ...]
    python -m tests.test_bus_security_machines outsider ENDPOINT ...
"""

from __future__ import annotations

import argparse
import base64
import functools
import json
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests import netlab
from tests.waiting import wait_for
from wire import keys

pytestmark = pytest.mark.slow

LAPTOP, ROBOT1, OUTSIDER = "10.88.0.1", "10.88.0.2", "10.88.0.3"
PORT = 7447


def events(log: Path) -> list[dict[str, Any]]:
    """The JSON lines a probe wrote to its log (other lines: Zenoh's and Python's own logging)."""
    if not log.exists():
        return []
    found = []
    for line in log.read_text(errors="replace").splitlines():
        if line.startswith("{"):
            try:
                found.append(json.loads(line))
            except ValueError:
                continue  # a line being written
    return found


def received(log: Path, key: str, sender: str | None = None) -> list[dict[str, Any]]:
    return [e for e in events(log) if e.get("key") == key and (sender is None or e.get("sender") == sender)]


@pytest.fixture
def team_network(tmp_path: Path) -> Iterator[tuple[netlab.Network, Path]]:
    reason = netlab.skip_reason()
    if reason:
        pytest.skip(reason)
    from pitchside.team_keys import create_team

    team = tmp_path / "team"
    create_team(team, "Net Team", ["robot1"], ["laptop"], router_host=LAPTOP, router_port=PORT)
    with netlab.network(["laptop", "robot1", "outsider"], tmp_path) as net:
        yield net, team


def test_a_robot_and_the_laptop_on_separate_machines_share_only_what_the_team_allows(
        team_network: tuple[netlab.Network, Path], tmp_path: Path) -> None:
    net, team = team_network
    laptop, robot1, outsider = net["laptop"], net["robot1"], net["outsider"]
    assert (laptop.address, robot1.address, outsider.address) == (LAPTOP, ROBOT1, OUTSIDER)
    logs = {name: tmp_path / f"{name}.log" for name in
            ("router", "robot", "robot_probe", "laptop_probe", "outsider", "laptop_outsider")}
    laptop.python(["pitchside.cli", "router", "--zenoh-config", str(team / "router.json5")], logs["router"])
    robot1.python(["pitchside.cli", "launch", "--robot-id", "robot1", "--zenoh-config", str(team / "robot1.json5"),
                   "tests.teststand"], logs["robot"])
    # one of robot1's nodes: joins the robot's router on loopback like every node (no file, no key)
    robot1.python(["tests.test_bus_security_machines", "probe", "--subscribe", "robot1/motor_goals",
                   "--subscribe", "robot1/cmd_vel"], logs["robot_probe"])
    # the laptop's member session, with the file the dashboard takes: it watches robot1 and tries to steer it
    # (and, as `ros2 topic list` and a subscriber of everything would, reads the graph's tokens and "**")
    laptop.python(["tests.test_bus_security_machines", "probe", "--zenoh-config", str(team / "laptop.json5"),
                   "--subscribe", "robot1/joint_states", "--put", "robot1/motor_goals=laptop",
                   "--put", "robot1/cmd_vel=laptop", "--graph"], logs["laptop_probe"])

    # robot1's data reaches the laptop, the laptop's cmd_vel reaches robot1's nodes
    wait_for(lambda: len(received(logs["laptop_probe"], "robot1/joint_states")) >= 3, timeout=60,
             what="robot1's joint_states at the laptop")
    # the ROS 2 graph of robot1's nodes (liveliness query) and its data through a subscription to "**"
    wait_for(lambda: any("/NN/%/%robot1/" in token
                         for e in events(logs["laptop_probe"]) for token in e.get("graph", [])),
             timeout=30, what="robot1's nodes in the laptop's graph query")
    wait_for(lambda: any(e.get("everything") == keys.topic_key("robot1", "joint_states")
                         for e in events(logs["laptop_probe"])), timeout=30,
             what="robot1's joint_states at the laptop's subscription to **")
    wait_for(lambda: received(logs["robot_probe"], "robot1/cmd_vel", "laptop"), timeout=30,
             what="the laptop's cmd_vel at robot1")

    # now that the routers are up and linked: outsiders on the third machine and on the laptop itself
    ca = _b64((team / "team-ca.pem").read_bytes())
    outsider.python(["tests.test_bus_security_machines", "outsider", "--ca", ca, f"tcp/{LAPTOP}:{PORT}",
                     f"tls/{LAPTOP}:{PORT}", f"tcp/{ROBOT1}:{PORT}", f"tls/{ROBOT1}:{PORT}"], logs["outsider"])
    laptop.python(["tests.test_bus_security_machines", "outsider", "--ca", ca, f"tcp/127.0.0.1:{PORT}",
                   f"tls/127.0.0.1:{PORT}"], logs["laptop_outsider"])
    def tried_enough(name: str) -> bool:
        return sum(1 for e in events(logs[name]) if "put" in e) >= 10

    for name in ("outsider", "laptop_outsider"):  # a few rounds of puts while the laptop's commands flow
        wait_for(functools.partial(tried_enough, name), timeout=60, what=f"the {name}'s attempts")
    before = len(received(logs["robot_probe"], "robot1/cmd_vel", "laptop"))
    wait_for(lambda: len(received(logs["robot_probe"], "robot1/cmd_vel", "laptop")) >= before + 3, timeout=30,
             what="the laptop's cmd_vel still arriving after the outsiders' attempts")
    # every laptop cmd_vel followed a refused motor_goals on the same session: those would have arrived first
    assert received(logs["robot_probe"], "robot1/motor_goals") == []
    assert received(logs["robot_probe"], "robot1/cmd_vel", "outsider") == []
    for name in ("outsider", "laptop_outsider"):
        attempts = [e for e in events(logs[name]) if "endpoint" in e]
        assert attempts and all(e["session"] is False for e in attempts), attempts  # no client got a session
        assert all(e["linked"] == 0 for e in events(logs[name]) if "put" in e), name  # its peer never got a link
        # its subscriptions to everything and to the graph's tokens heard nothing
        assert all(e["heard"] == 0 and e["tokens"] == 0 for e in events(logs[name]) if "put" in e), name
    # the laptop's router is there to be reached (and refuses); on robot1 nothing listens to the network at all
    reachable = {e["endpoint"]: e["tcp_open"] for e in events(logs["outsider"]) if "endpoint" in e}
    assert reachable == {f"tcp/{LAPTOP}:{PORT}": True, f"tls/{LAPTOP}:{PORT}": True,
                         f"tcp/{ROBOT1}:{PORT}": False, f"tls/{ROBOT1}:{PORT}": False}

    # robot1 listens on loopback only, and talks to the laptop through one link: its router's
    listening = robot1.run(["ss", "-Hltn"], check=True).stdout.split("\n")
    local = [line.split()[3] for line in listening if line.strip()]
    assert local and all(a.startswith(("127.0.0.1:", "[::1]:", "[::ffff:127.0.0.1]:")) for a in local), local
    established = robot1.run(["ss", "-Htn", "state", "established", "dst", LAPTOP], check=True).stdout
    assert len([line for line in established.split("\n") if line.strip()]) == 1, established


def _b64(data: bytes) -> str:
    return base64.b64encode(data).decode("ascii")


# --- processes on the machines ---------------------------------------------------------------------------------

def _say(event: dict[str, Any]) -> None:
    print(json.dumps(event), flush=True)


def probe(argv: list[str]) -> None:
    """A team session: reports samples of --subscribe keys (control topics with their sender), puts --put
    messages in the order given, every 0.2 s, until stopped."""
    from robot_nodes.runtime import BusConfig, open_session
    from tests.test_bus_security import drive, goals, sender_of
    from wire import keys

    parser = argparse.ArgumentParser()
    parser.add_argument("--zenoh-config", default=None)
    parser.add_argument("--subscribe", action="append", default=[])
    parser.add_argument("--put", action="append", default=[])
    parser.add_argument("--graph", action="store_true",
                        help="also report the graph's tokens (a liveliness query) and the first sample of each key "
                        "of a subscription to **, as a member's ros2 tools would read them")
    args = parser.parse_args(argv)
    session = open_session(BusConfig(config_file=args.zenoh_config))
    lock = threading.Lock()
    heard: set[str] = set()

    def on_everything(sample: Any) -> None:
        key = str(sample.key_expr)
        with lock:
            if key not in heard:
                heard.add(key)
                _say({"everything": key})

    everything = session.declare_subscriber("**", on_everything) if args.graph else None

    def on_sample(name: str) -> Any:
        topic = name.split("/", 1)[1]

        def report(sample: Any) -> None:
            raw = sample.payload.to_bytes()
            event: dict[str, Any] = {"key": name}
            if topic in ("motor_goals", "cmd_vel"):
                event["sender"] = sender_of(topic, raw)
            with lock:
                _say(event)
        return report

    subscribers = [session.declare_subscriber(keys.topic_key(*name.split("/", 1)), on_sample(name))
                   for name in args.subscribe]
    puts = []
    for item in args.put:
        name, _, sender = item.partition("=")
        topic = name.split("/", 1)[1]
        puts.append((session.declare_publisher(keys.topic_key(*name.split("/", 1))),
                     drive(sender) if topic == "cmd_vel" else goals(sender)))
    with lock:
        _say({"ready": True, "subscribers": len(subscribers), "everything": everything is not None})
    while True:
        for publisher, payload in puts:
            publisher.put(payload)
        if args.graph:
            tokens = [str(r.ok.key_expr) for r in session.liveliness().get(keys.graph_tokens_key(), timeout=1.0)
                      if r.ok is not None]
            with lock:
                _say({"graph": tokens})
        time.sleep(0.2)


def outsider(argv: list[str]) -> None:
    """Someone without the team's certificates (it may know the team CA, which is public): a client at each
    endpoint, then a peer that keeps putting robot1's motor goals and cmd_vel at all of them."""
    import zenoh

    from tests.test_bus_security import drive, goals
    from wire import keys

    parser = argparse.ArgumentParser()
    parser.add_argument("--ca", required=True, help="the team CA certificate, base64 (the TLS handshake shows it)")
    parser.add_argument("endpoints", nargs="+")
    args = parser.parse_args(argv)

    def config(mode: str, endpoints: list[str]) -> zenoh.Config:
        return zenoh.Config.from_json5(json.dumps({
            "mode": mode, "scouting": {"multicast": {"enabled": False}},
            "connect": {"endpoints": endpoints, "timeout_ms": 2000, "exit_on_failure": mode == "client"},
            "transport": {"link": {"tls": {"root_ca_certificate_base64": args.ca,
                                           "verify_name_on_connect": False}}}}))

    for endpoint in args.endpoints:
        host, _, port = endpoint.partition("/")[2].rpartition(":")
        try:  # is anything listening there at all?
            socket.create_connection((host, int(port)), timeout=2).close()
            tcp_open = True
        except OSError:
            tcp_open = False
        try:
            session = zenoh.open(config("client", [endpoint]))
        except zenoh.ZError as exc:
            _say({"endpoint": endpoint, "tcp_open": tcp_open, "session": False, "error": str(exc)[:200]})
        else:
            _say({"endpoint": endpoint, "tcp_open": tcp_open, "session": True})
            session.close()
    session = zenoh.open(config("peer", args.endpoints))
    goals_key, cmd_key = keys.topic_key("robot1", "motor_goals"), keys.topic_key("robot1", "cmd_vel")
    heard: list[str] = []
    tokens: list[str] = []
    # what a stranger's `ros2 topic list` and a subscriber of everything would read: nothing, without a link
    session.declare_subscriber("**", lambda sample: heard.append(str(sample.key_expr)),
                               allowed_origin=zenoh.Locality.REMOTE)  # not its own puts
    session.liveliness().declare_subscriber("@ros2_lv/**", lambda s: tokens.append(str(s.key_expr)), history=True)
    while True:
        session.put(goals_key, goals("outsider"))
        session.put(cmd_key, drive("outsider"))
        _say({"put": True, "linked": len(list(session.info.routers_zid())) + len(list(session.info.peers_zid())),
              "heard": len(heard), "tokens": len(tokens)})
        time.sleep(0.2)


if __name__ == "__main__":
    import sys

    {"probe": probe, "outsider": outsider}[sys.argv[1]](sys.argv[2:])
