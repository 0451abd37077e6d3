"""Node logs as messages: what a node logs goes out as rcl_interfaces/msg/Log on ROS 2's /rosout (one topic for
every robot, the logger name <robot>.<node> says whose), a flood is cut by the rate limit and counted, and two
robots' nodes in one process never log under each other's name."""

from __future__ import annotations

import logging
import threading
from collections.abc import Iterator
from typing import Any

import pytest
import zenoh

import schemas
from robot_nodes.runtime import Node
from robot_nodes.runtime.rosout import BURST
from schemas.std import DiagnosticArray, Log
from tests.waiting import wait_for
from wire import keys
from wire.bus import BusConfig

# ROS 2's /rosout in domain 0 (rmw_zenoh's key of it, as a ROS 2 node subscribes)
ROSOUT_KEY = ("0/rosout/rcl_interfaces::msg::dds_::Log_/"
              "RIHS01_e28ce254ca8abc06abf92773b74602cdbf116ed34fbaf294fb9f81da9f318eac")


@pytest.fixture(autouse=True)
def info_level(caplog: pytest.LogCaptureFixture) -> Iterator[None]:
    """As ``run`` sets it for a node process (--log-level INFO); a test process starts at WARNING."""
    with caplog.at_level(logging.INFO, logger="pitchside"):
        yield


class Chatty(Node):
    __test__ = False
    name = "chatty"


class Received:
    """Every Log of a robot's nodes on /rosout, decoded (told apart by the logger name, as ROS 2 names it)."""

    def __init__(self, client: zenoh.Session, robot: str) -> None:
        self.logs: list[Log] = []
        self.robot = robot
        self._lock = threading.Lock()
        self._sub = client.declare_subscriber(ROSOUT_KEY, self._on)

    def _on(self, sample: Any) -> None:
        log = schemas.decode(sample.payload.to_bytes(), Log)
        if log.name.startswith(self.robot + "."):
            with self._lock:
                self.logs.append(log)

    def texts(self) -> list[str]:
        with self._lock:
            return [log.msg for log in self.logs]


def test_a_nodes_records_go_out_on_rosout(bus: BusConfig, client: zenoh.Session) -> None:
    received = Received(client, "r1")
    node = Chatty("r1", bus).start()
    try:
        wait_for(lambda: (node.log.info("hello %s", "pitch") or "hello pitch" in received.texts()), timeout=10,
                 interval=0.2, what="the first record routed")
        node.log.debug("not sent: below INFO")
        node.log.warning("servo %d hot", 7)
        try:
            raise ValueError("bad value")
        except ValueError:
            node.log.exception("step failed")
        wait_for(lambda: any(t.startswith("step failed") for t in received.texts()), timeout=10, what="the error")
        by_text = {log.msg.split("\n")[0]: log for log in received.logs}
        assert by_text["servo 7 hot"].level == Log.WARN and by_text["servo 7 hot"].name == "r1.chatty"
        assert by_text["servo 7 hot"].file.endswith("test_rosout.py") and by_text["servo 7 hot"].line > 0
        assert by_text["hello pitch"].level == Log.INFO
        failed = by_text["step failed"]
        assert failed.level == Log.ERROR and "ValueError: bad value" in failed.msg and "Traceback" in failed.msg
        assert not any("below INFO" in t for t in received.texts())
    finally:
        node.shutdown()


def test_a_flood_is_cut_and_counted(bus: BusConfig, client: zenoh.Session) -> None:
    received = Received(client, "r1")
    diagnostics: list[DiagnosticArray] = []
    sub = client.declare_subscriber(keys.topic_key("r1", "diagnostics"),
                                    lambda s: diagnostics.append(schemas.decode(s.payload.to_bytes(), DiagnosticArray)))
    node = Chatty("r1", bus).start()
    try:
        wait_for(lambda: (node.log.info("ready") or "ready" in received.texts()), timeout=10, interval=0.2,
                 what="the first record routed")
        for i in range(5000):
            node.log.warning("flood %d", i)

        def dropped() -> int:
            values = [{kv.key: kv.value for kv in d.status[0].values} for d in diagnostics if d.status]
            return max((int(v.get("rosout_dropped", 0)) for v in values), default=0)

        def flood() -> list[str]:
            return [t for t in received.texts() if t.startswith("flood")]

        # what is not sent is counted: the diagnostics after the flood (not one sent while it ran) say so
        wait_for(lambda: len(flood()) + dropped() >= 5000 - 200, timeout=10, what="the dropped records counted")
        assert len(flood()) <= BURST + 200, len(flood())  # the burst and what the rate refilled meanwhile
    finally:
        node.shutdown()
        sub.undeclare()


def test_two_robots_nodes_in_one_process_log_apart(bus: BusConfig, client: zenoh.Session) -> None:
    one, two = Received(client, "r1"), Received(client, "r2")
    first, second = Chatty("r1", bus).start(), Chatty("r2", bus).start()
    try:
        wait_for(lambda: (first.log.info("from r1") or second.log.info("from r2")
                          or ("from r1" in one.texts() and "from r2" in two.texts())),
                 timeout=10, interval=0.2, what="both robots' records")
        assert "from r2" not in one.texts() and "from r1" not in two.texts()
    finally:
        first.shutdown()
        second.shutdown()
