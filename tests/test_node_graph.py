"""The node graph (issue 17 point 6, issue 44): every node declares rmw_zenoh's liveliness tokens for itself, its
publishers, subscriptions and services (``@ros2_lv/<domain>/...``); the server reads them (server/node_graph.py on
wire.ros2.graph) for GET /api/graph and Foxglove's ConnectionGraph, as ``ros2 node list`` and ``ros2 topic info -v``
read them. Real node processes on a real router; a killed process's entries go without it saying goodbye."""

from __future__ import annotations

import json
import logging
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import zenoh

from robot_nodes.runtime import BusConfig, Node, open_session
from server.node_graph import GraphEntry, NodeGraph, topic_links
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
            topics = {t["topic"]: t for t in body["topics"]}
            echo = next(n for n in body["nodes"] if n["id"] == "/g1/echo")
            assert echo["namespace"] == "/g1" and echo["node"] == "echo"
            assert "/g1/joint_states" in echo["subscribes"] and "/g1/robot_state" in echo["publishes"]
            assert "/rosout" in echo["publishes"]  # ROS 2's /rosout, every node's
            assert {"/g1/echo", "/g1/talker", "/g2/talker"} <= set(topics["/rosout"]["publishers"])
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
        assert {GraphEntry("/c1/talker", "pub", "/c1/diagnostics"), GraphEntry("/c1/echo", "pub", "/c1/diagnostics"),
                GraphEntry("/c1/echo", "pub", "/rosout")} <= set(watched.snapshot())
        assert [n.id for n in watched.nodes()] == ["/c1/echo", "/c1/talker"]
        echo.shutdown()
        wait_for(lambda: not any(e.node == "/c1/echo" for e in watched.snapshot()), timeout=20, what="echo gone")
        assert any(e.node == "/c1/talker" for e in watched.snapshot())  # the session and its other node stay
        assert topic_links(watched.snapshot())["/c1/joint_states"].subscribers == set()
        talker.shutdown()
        wait_for(lambda: watched.snapshot() == [] and watched.nodes() == [], timeout=20, what="talker gone")
    finally:
        session.close()
        watched.stop()
        link.close()


def test_no_graph_in_match_mode(tmp_path: Path) -> None:
    with dashboard_server(["--match", "--allow-dev-key", "--no-telemetry", "--no-foxglove"], tmp_path) as server:
        body = graph(server)
    assert body["available"] is False and "match mode" in body["reason"] and body["nodes"] == []


def test_a_token_from_outside_the_rules_is_counted_logged_once_and_left_out(
        bus: BusConfig, client: zenoh.Session, caplog: pytest.LogCaptureFixture) -> None:
    """Tokens come from the network: one that is not rmw_zenoh's is counted and logged once, never listed."""
    link = ZenohLink(bus, match_mode=False)
    watched = NodeGraph(link)
    watched.start()
    zid = str(client.zid())
    try:
        with caplog.at_level(logging.WARNING, logger="wire.ros2.graph"):
            bad = [client.liveliness().declare_token(key) for key in (
                "@ros2_lv/0/x/not-a-number/1/NN/%/%r1/node",  # a node id that is no number
                f"@ros2_lv/0/{zid}/9/10/MP/%/%r1/node/%r1%joint_states/not_a_type/RIHS01_00/::,:,:,:,,",
                f"@ros2_lv/0/{zid}/9/9/XX/%/%r1/node")]  # no entity kind
            fine = client.liveliness().declare_token(f"@ros2_lv/0/{zid}/9/9/NN/%/%r1/node")
            wait_for(lambda: watched.bad_keys == 3 and [n.id for n in watched.nodes()] == ["/r1/node"], timeout=20,
                     what="all four seen")
        warnings = [r for r in caplog.records if r.name == "wire.ros2.graph"]
        assert len(warnings) == 1 and "not rmw_zenoh's" in warnings[0].getMessage()
        assert watched.snapshot() == []  # a node without entries, nothing of the bad ones
        for token in [*bad, fine]:
            token.undeclare()
        wait_for(lambda: watched.nodes() == [], timeout=20, what="the node gone")
    finally:
        watched.stop()
        link.close()


class EveryRobotsJointStates(Node):
    __test__ = False
    name = "watcher"

    def setup(self) -> None:
        self.heard: set[str] = set()
        self.subscribe("joint_states", lambda robot, msg: self.heard.add(robot), robot="*")


def test_a_subscription_to_every_robot_shows_for_each_robot_it_hears(bus: BusConfig) -> None:
    """``robot="*"`` has no single ROS 2 name: the node declares a subscription token per robot it hears from, as
    if it had subscribed to each of those robots' topics by name (what ``ros2 topic info -v`` can show)."""
    link = ZenohLink(bus, match_mode=False)
    watched = NodeGraph(link)
    watched.start()
    watcher = EveryRobotsJointStates("w1", bus).start()
    talkers = [Talker(robot, bus, overrides={"rate_hz": 20}).start() for robot in ("a1", "b1")]
    try:
        def subscribers(topic: str) -> set[str]:
            links = topic_links(watched.snapshot()).get(topic)
            return links.subscribers if links is not None else set()

        wait_for(lambda: subscribers("/a1/joint_states") == {"/w1/watcher"} == subscribers("/b1/joint_states"),
                 timeout=20, what="a token for each robot heard")
        assert watcher.heard == {"a1", "b1"}
        assert not any(e.node == "/w1/watcher" and e.role == "sub" and e.name.startswith("/w1/")
                       for e in watched.snapshot())  # nothing for its own robot, which publishes no joint_states
    finally:
        for node in (*talkers, watcher):
            node.shutdown()
        watched.stop()
        link.close()
