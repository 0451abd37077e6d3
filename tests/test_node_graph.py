"""The node graph (issue 17 point 6): nodes announce what they publish, subscribe and serve as Zenoh liveliness
tokens (robot_nodes/runtime/graph.py); the server reads them (server/node_graph.py) for GET /api/graph and Foxglove's
ConnectionGraph. Real node processes on a real router; a killed process's entries go without it saying goodbye."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import zenoh

from robot_nodes.runtime import BusConfig, open_session
from server.node_graph import NodeGraph, topic_links
from server.zenoh_link import ZenohLink
from tests.dashboard_server import RunningServer, dashboard_server
from tests.foxglove_node import foxglove_url, node_client
from tests.proc_nodes import Echo, Talker
from tests.support import REPO, free_port
from tests.waiting import wait_for


def graph(server: RunningServer) -> dict[str, Any]:
    reply = server.http.get(f"{server.url}/api/graph")
    assert reply.status_code == 200, reply.text
    body: dict[str, Any] = reply.json()
    return body


def node_ids(server: RunningServer) -> set[str]:
    return {n["id"] for n in graph(server)["nodes"]}


def test_the_graph_follows_node_processes_and_a_killed_one_leaves_it(router_endpoint: str, tmp_path: Path) -> None:
    composed = subprocess.Popen([sys.executable, "-m", "robot_nodes.compose", "tests.proc_nodes:Talker",
                                 "tests.proc_nodes:Echo", "--robot-id", "g1", "--connect", router_endpoint,
                                 "--set", "talker.rate_hz=20"], cwd=REPO)
    alone = subprocess.Popen([sys.executable, "-m", "tests.proc_nodes", "talker", "--robot-id", "g2", "--connect",
                              router_endpoint, "--set", "rate_hz=20"], cwd=REPO)
    try:
        with dashboard_server(["--connect", router_endpoint, "--no-telemetry", "--foxglove-port", str(free_port())],
                              tmp_path) as server:
            def announced() -> bool:
                topics = {t["topic"]: t for t in graph(server)["topics"]}
                return topics.get("/g1/joint_states", {}).get("subscribers") == ["/g1/echo"] and \
                    topics.get("/g1/robot_state", {}).get("publishers") == ["/g1/echo"] and \
                    topics.get("/g2/joint_states", {}).get("publishers") == ["/g2/talker"]

            wait_for(announced, timeout=60, interval=0.2, what="the three nodes in the graph")
            body = graph(server)
            assert body["available"] is True
            echo = next(n for n in body["nodes"] if n["id"] == "/g1/echo")
            assert "joint_states" in echo["subscribes"] and "robot_state" in echo["publishes"]
            topics = {t["topic"]: t for t in body["topics"]}
            assert topics["/g1/joint_states"]["publishers"] == ["/g1/talker"]
            assert topics["/g1/joint_states"]["subscribers"] == ["/g1/echo"]
            assert topics["/g2/joint_states"]["subscribers"] == []  # g2's talker alone: nobody listens
            # Foxglove's topic graph: the same, then the killed process's topics removed
            url = foxglove_url(server.output())
            assert url is not None
            session = node_client("session", url, "--script", json.dumps([
                {"op": "subscribeGraph"}, {"op": "waitGraphRemoved", "topic": "/g1/joint_states"}]))
            assert session.stdout is not None
            assert json.loads(session.stdout.readline()) == {"progress": "subscribeGraph"}
            composed.send_signal(signal.SIGKILL)  # no goodbye: Zenoh drops its tokens with the connection
            composed.wait(10)
            wait_for(lambda: not any(n.startswith("/g1/") for n in node_ids(server)), timeout=30, interval=0.2,
                     what="g1's nodes gone")
            assert "/g2/talker" in node_ids(server)
            out, err = session.communicate(timeout=60)
            got = json.loads(out.splitlines()[-1])
            assert got["errors"] == [], (got["errors"], err)
            published: dict[str, list[str]] = {}  # the graph as the client built it from the updates (diffs)
            subscribed: dict[str, list[str]] = {}
            for update in got["graph"]:
                if "/g1/joint_states" in update.get("removedTopics", []):
                    break
                published.update({t["name"]: t["publisherIds"] for t in update["publishedTopics"]})
                subscribed.update({t["name"]: t["subscriberIds"] for t in update["subscribedTopics"]})
            assert published["/g1/joint_states"] == ["/g1/talker"] and published["/g2/joint_states"] == ["/g2/talker"]
            assert subscribed["/g1/joint_states"] == ["/g1/echo"]
            assert any("/g1/joint_states" in m.get("removedTopics", []) for m in got["graph"][1:])
    finally:
        for proc in (composed, alone):
            if proc.poll() is None:
                proc.terminate()
                proc.wait(10)


def test_nodes_composed_in_one_session_leave_the_graph_one_by_one(bus: BusConfig) -> None:
    """Composed nodes share their process's Zenoh session; each holds its own tokens, so closing one takes away
    its entries only (and the other's, once it closes too)."""
    link = ZenohLink(bus, match_mode=False)
    watched = NodeGraph(link)
    watched.start()
    session = open_session(bus)
    try:
        talker, echo = Talker("c1", session).start(), Echo("c1", session).start()
        def joint_states_links() -> tuple[set[str], set[str]] | None:
            links = topic_links(watched.snapshot()).get("/c1/joint_states")
            return (links.publishers, links.subscribers) if links is not None else None

        wait_for(lambda: joint_states_links() == ({"/c1/talker"}, {"/c1/echo"}), timeout=20,
                 what="both composed nodes announced")
        assert {("c1", "talker", "pub", "diagnostics"), ("c1", "echo", "pub", "diagnostics")} <= \
            {(e.robot, e.node, e.role, e.name) for e in watched.snapshot()}
        echo.shutdown()
        wait_for(lambda: not any(e.node == "echo" for e in watched.snapshot()), timeout=20, what="echo gone")
        assert any(e.node == "talker" for e in watched.snapshot())  # the session and its other node stay
        assert topic_links(watched.snapshot())["/c1/joint_states"].subscribers == set()
        talker.shutdown()
        wait_for(lambda: watched.snapshot() == [], timeout=20, what="talker gone")
    finally:
        session.close()
        watched.stop()
        link.close()


def test_no_graph_in_match_mode(tmp_path: Path) -> None:
    with dashboard_server(["--match", "--allow-dev-key", "--no-telemetry", "--no-foxglove"], tmp_path) as server:
        body = graph(server)
    assert body["available"] is False and "match mode" in body["reason"] and body["nodes"] == []


def test_a_token_from_outside_the_rules_is_left_out(bus: BusConfig, client: zenoh.Session) -> None:
    """Keys come from the network: one that breaks the naming rules is counted, never listed."""
    link = ZenohLink(bus, match_mode=False)
    watched = NodeGraph(link)
    watched.start()
    try:
        bad = client.liveliness().declare_token("pitchside/r1/_graph/bad-node/pub/joint_states")
        fine = client.liveliness().declare_token("pitchside/r1/_graph/node/pub/joint_states")
        wait_for(lambda: watched.bad_keys >= 1 and len(watched.snapshot()) == 1, timeout=20, what="both seen")
        assert [(e.robot, e.node, e.role, e.name) for e in watched.snapshot()] == [("r1", "node", "pub",
                                                                                    "joint_states")]
        bad.undeclare()
        fine.undeclare()
    finally:
        watched.stop()
        link.close()
