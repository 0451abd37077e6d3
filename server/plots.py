"""Plots: the server feeds rerun with downsampled numbers and the HCM and game states as named lanes, all on one
time axis, in a viewer the dashboard embeds.

rerun's server (server.rerun_server, a child process on loopback) serves its web viewer from the wheel (offline)
and the data over gRPC; the browser reaches both only through the dashboard (server.routers.plots). What
is plotted is decided in server.plot_series; here it is logged, into that server over gRPC. Every numeric stream is
thinned by the hub to ``plots_max_hz``; the state streams are few messages a second and taken whole, so a short
state (FALLING) is never thinned away, and only their changes are logged. rerun's gRPC server keeps at most
``config.plots_memory`` of history (256 MiB unless ``--plots-memory``) for viewers that connect late. rerun's own
usage analytics: ``TELEMETRY_ENABLED`` is forced off here; the SDK's analytics setting lives in rerun's config file
(``rerun analytics disable``) and fails harmlessly offline; the server's are off.
"""

from __future__ import annotations

import asyncio
import colorsys
import contextlib
import logging
import os
import time
import zlib
from typing import Any

import numpy as np

from server.config import ServerConfig
from server.hub import Hub, HubMessage, Subscriber
from server.plot_series import CURATED_TOPICS, STATE_TOPICS, RobotSeries, states_of, topic_series
from server.rerun_server import RerunServer

log = logging.getLogger(__name__)
BLUEPRINT_EVERY_S = 2.0  # a new robot or topic re-sends the layout, at most this often
# numbers gathered this long go to rerun as one column per entity: a call per message and entity was a third of the
# server's CPU with 8 robots (each entity gets plots_max_hz rows a second, so a shorter batch saves little); the
# viewer's lines grow in steps of half a second, behind rerun's own latency of seconds
BATCH_S = 0.5


def palette(n: int, start: int = 0) -> list[tuple[int, int, int]]:
    """n distinct colours (golden-ratio hues from ``start``): a joint's position and goal share the joint's colour,
    and entities in one view (each node's loop rates) start at different hues."""
    return [tuple(int(255 * c) for c in colorsys.hsv_to_rgb((0.61803 * (start + i)) % 1.0, 0.75, 0.95))  # type: ignore[misc]
            for i in range(n)]


def blueprint(topics: dict[str, list[str]]) -> Any:
    """Per robot: a grid of joints (position lines, goal dots), IMU, loop rates and the HCM/game state lanes, and
    a tab with one view per topic plotted whole."""
    import rerun.blueprint as rrb

    tabs: list[Any] = []
    for robot, robot_topics in topics.items():
        tabs.append(rrb.Grid(
            rrb.TimeSeriesView(origin=f"/{robot}/joints", name="joints: position (lines) vs goal (dots)"),
            rrb.TimeSeriesView(origin=f"/{robot}/imu", name="IMU"),
            rrb.TimeSeriesView(origin=f"/{robot}/loop_rates", name="loop rates (Hz)"),
            rrb.StateTimelineView(origin=f"/{robot}/lanes", name="HCM state, game state, penalized"),
            name=robot))
        if robot_topics:
            tabs.append(rrb.Tabs(*[rrb.TimeSeriesView(origin=f"/{robot}/topics/{topic}", name=topic)
                                   for topic in sorted(robot_topics)], name=f"{robot}: every topic"))
    return rrb.Blueprint(rrb.Tabs(*tabs), collapse_panels=True)


class PlotRows:
    """The rows of each entity gathered in one batch: stamps and values, sent as columns (``send_columns``)."""

    def __init__(self) -> None:
        self.entities: dict[str, tuple[list[float], list[tuple[float, ...]]]] = {}
        self.newest_s = 0.0  # the newest stamp gathered

    def add(self, entity: str, stamp: float, values: tuple[float, ...]) -> None:
        self.newest_s = max(self.newest_s, stamp)
        stamps, rows = self.entities.setdefault(entity, ([], []))
        stamps.append(stamp)
        rows.append(values)

    def send_pending(self, entity: str, rec: Any) -> None:
        """What is gathered for ``entity`` to rerun now, one call; rows may differ in length (a robot's joints)."""
        import rerun as rr

        gathered = self.entities.pop(entity, None)
        if gathered is None:
            return
        stamps, rows = gathered
        flat = np.fromiter((v for row in rows for v in row), dtype=np.float64)
        rec.send_columns(entity, indexes=[rr.TimeColumn("time", timestamp=np.asarray(stamps))],
                         columns=rr.Scalars.columns(scalars=flat).partition([len(row) for row in rows]))


class PlotFeed:
    """A hub subscriber that logs the plot series into one rerun recording served to the browser."""

    def __init__(self, hub: Hub, config: ServerConfig) -> None:
        self.hub = hub
        self.config = config
        self.logged = 0
        self.state_changes = 0
        self.newest_sent_s = 0.0  # the newest stamp sent to rerun (s since the epoch): how far the server is behind
        self.topics: dict[str, list[str]] = {}  # robot -> topics whose every number is plotted, in order
        self.chosen: set[tuple[str, str]] = set()  # (robot or "*", topic) asked for besides the curated series
        self.rec: Any = None
        self.server = RerunServer(config.plots_grpc_port, config.plots_web_port, config.plots_memory)
        self._robots: dict[str, RobotSeries] = {}
        self._states: dict[str, str] = {}  # entity path -> the state last logged there
        self._names: dict[str, tuple[str, ...]] = {}  # entity path -> the series names logged for it
        self._blueprint_due = False
        self._blueprint_sent = 0.0
        self._sub: Subscriber | None = None
        self._task: asyncio.Task[None] | None = None

    @property
    def robots(self) -> list[str]:
        return list(self.topics)

    def urls(self) -> dict[str, int]:
        """rerun's loopback ports: its web viewer's files and its gRPC server (a native viewer on this laptop can
        read the plots there: ``rerun rerun+http://127.0.0.1:<grpc_port>/proxy``)."""
        return {"web_port": self.server.web_port, "grpc_port": self.server.grpc_port}

    def status(self) -> dict[str, Any]:
        """What the viewer is fed: messages plotted so far, state changes logged, and the robots with a tab."""
        return {**self.urls(), "server_running": self.server.running, "logged": self.logged,
                "state_changes": self.state_changes, "newest_sent_s": self.newest_sent_s, "robots": self.robots,
                "series": len(self._names), "topics": {robot: list(t) for robot, t in self.topics.items()},
                "chosen": [{"robot": robot, "topic": topic} for robot, topic in sorted(self.chosen)],
                "all_topics": self.config.plots_all_topics}

    def wants(self, robot: str, topic: str) -> bool:
        """Is every number of this topic plotted (``--plots-all-topics``, or chosen in the panel)?"""
        return self.config.plots_all_topics or (robot, topic) in self.chosen or ("*", topic) in self.chosen

    def choose(self, robot: str, topic: str, plotted: bool) -> None:
        """Plots every number of a topic from now on (a tab of its own), or stops; what was plotted stays."""
        own_subscription = topic not in CURATED_TOPICS + STATE_TOPICS and not self.config.plots_all_topics
        if plotted:
            self.chosen.add((robot, topic))
            if own_subscription and self._sub is not None:
                self._sub.subscribe(robot, topic, max_hz=self.config.plots_max_hz)
            return
        self.chosen.discard((robot, topic))
        if own_subscription and self._sub is not None:
            self._sub.unsubscribe(robot, topic)
        for other, topics in self.topics.items():
            if topic in topics and not self.wants(other, topic) and robot in ("*", other):
                topics.remove(topic)
                self._blueprint_due = True

    async def start(self) -> None:
        os.environ["TELEMETRY_ENABLED"] = "false"
        import rerun as rr

        await self.server.start()
        try:
            self.rec = rr.RecordingStream("pitchside")
            self.rec.connect_grpc(self.server.url)
        except Exception:
            await self.server.stop()
            raise
        self._sub = self.hub.subscribe("plots", maxlen=4096)
        self.hub.on_robot_gone(self.forget)
        for topic in STATE_TOPICS:  # first: a subscriber takes a message by its first matching subscription
            self._sub.subscribe("*", topic)
        for topic in CURATED_TOPICS if not self.config.plots_all_topics else ("*",):
            self._sub.subscribe("*", topic, max_hz=self.config.plots_max_hz)
        self._task = asyncio.create_task(self._run())

    async def _run(self) -> None:
        assert self._sub is not None
        while True:
            await self._sub.wait()
            await asyncio.sleep(BATCH_S)  # half a second of every robot's numbers goes to rerun at once
            rows = PlotRows()
            while batch := self._sub.drain(limit=4096):
                for msg in batch:
                    self._take(msg, rows)
            self._send(rows)
            if self._blueprint_due and time.monotonic() - self._blueprint_sent > BLUEPRINT_EVERY_S:
                self.rec.send_blueprint(blueprint(self.topics))
                self._blueprint_due, self._blueprint_sent = False, time.monotonic()

    def forget(self, robot: str) -> None:
        """A robot gone for good (a closed replay's): its tabs leave the viewer and its lines are cleared."""
        import rerun as rr

        known = self.topics.pop(robot, None) is not None
        self._robots.pop(robot, None)
        for table in (self._states, self._names):
            for entity in [e for e in table if e.startswith(f"{robot}/")]:
                del table[entity]
        if known and self.rec is not None:
            self.rec.log(robot, rr.Clear(recursive=True))
            self.rec.send_blueprint(blueprint(self.topics))  # at once: no tab of a closed log lingers
            self._blueprint_sent = time.monotonic()

    def _take(self, msg: HubMessage, rows: PlotRows) -> None:
        """One message's numbers into ``rows``; its state changes logged at once (a few a second at most)."""
        robot = self._robots.setdefault(msg.robot, RobotSeries())
        try:
            series = robot.series(msg)
            topics = topic_series(msg) if self.wants(msg.robot, msg.topic) else {}
            states = states_of(msg)
        except Exception as exc:  # undecodable input is counted by the hub, not plotted
            log.debug("not plotted: %s", exc)
            return
        if msg.robot not in self.topics:
            self.topics[msg.robot] = []
            self._blueprint_due = True
        if topics and msg.topic not in self.topics[msg.robot]:
            self.topics[msg.robot].append(msg.topic)
            self._blueprint_due = True
        for path, s in (series | topics).items():
            entity = f"{msg.robot}/{path}"
            if self._names.get(entity) != s.names:
                rows.send_pending(entity, self.rec)  # rows of the old names go out under their style
                self._style(entity, path, s.names)
            rows.add(entity, msg.stamp, s.values)
        self._log_states(msg.robot, msg.stamp, states)
        self.logged += 1

    def _style(self, entity: str, path: str, names: tuple[str, ...]) -> None:
        """The lines' names and colours, once per entity (again when its names change)."""
        import rerun as rr

        self._names[entity] = names
        colours = palette(len(names), 0 if path.startswith("joints/") else zlib.crc32(path.encode()) % 97)
        style = rr.SeriesPoints(names=[f"{n} goal" for n in names], colors=colours,
                                marker_sizes=[3.0] * len(names)) if path == "joints/goal" else \
            rr.SeriesLines(names=list(names), colors=colours)
        self.rec.log(entity, style, static=True)

    def _log_states(self, robot: str, stamp: float, states: dict[str, str]) -> None:
        import rerun as rr

        for path, state in states.items():
            entity = f"{robot}/{path}"
            if self._states.get(entity) != state:
                self._states[entity] = state
                self.rec.set_time("time", timestamp=stamp)
                self.rec.log(entity, rr.StateChange(state=state))
                self.state_changes += 1

    def _send(self, rows: PlotRows) -> None:
        for entity in list(rows.entities):
            rows.send_pending(entity, self.rec)
        self.newest_sent_s = max(self.newest_sent_s, rows.newest_s)

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(BaseException):
                await self._task
        if self._sub is not None:
            self._sub.close()
        if self.rec is not None:
            with contextlib.suppress(Exception):
                await asyncio.to_thread(self.rec.disconnect)  # flushes what is still queued for the server
        await self.server.stop()
