"""The GameController monitor source: the dashboard registers with an HSL GameController as a monitor (off by
default, ``pitchside serve --gc-monitor HOST``) and shows the true game state and every robot's status packet,
both teams', as robots of their own (``gc<team>-<player>``): their gamestate (from the true state), position,
fallen flag and ball.

It asks the GameController, never a robot, for data, and is meant for the team area (a laptop beside the
GameController), not the robots' network path; the GameController refuses hosts that sent status packets. The
status poses come in each team's frame (+x towards the goal it attacks); the field view draws the packet's first
team (the one defending the operator's left goal) defending -x, the second turned half round.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import time
from typing import Any

import schemas
from server.hub import Hub, HubMessage
from server.sources import Source, SourceError
from wire.gamecontroller.gamestate import gamestate_fields
from wire.gamecontroller.monitor import (
    MONITOR_DATA_PORT,
    MONITOR_FORWARD_PORT,
    MONITOR_REQUEST_PORT,
    GameControllerMonitor,
    RobotSeen,
)
from wire.gamecontroller.packets import GameControlData

PERIOD_S = 0.5  # the GameController forwards statuses at 0.5-2 Hz and sends the true state at 2 Hz
ROBOT_GONE_S = 5.0  # a robot whose status has not come for this long is no longer shown
BALL_SEEN_S = 3.0  # a ball the robot last saw longer ago is not drawn
_HL = "humanoid_league_msgs/msg/"
_FALLEN, _CONTROLLABLE = 2, 0  # RobotControlState


def robot_id(team: int, player: int) -> str:
    return f"gc{team}-{player}"


def robot_messages(seen: RobotSeen, truth: GameControlData | None) -> list[tuple[str, str, Any]]:
    """(topic, type, message) for one robot's status and, when known, its team's true state."""
    status = seen.status
    out: list[tuple[str, str, Any]] = []
    second_team = truth is not None and truth.teams[1].team_number == status.team
    if truth is not None:
        fields = gamestate_fields(truth, status.team, status.player)
        if fields is not None:
            out.append(("gamestate", _HL + "GameState", schemas.make(_HL + "GameState", header=schemas.header(),
                                                                      **fields)))
    x_mm, y_mm, theta = status.pose_mm
    if all(math.isfinite(v) for v in status.pose_mm):
        # the team's frame -> the field view's: the second team defends +x, so its frame is turned half round
        x, y, yaw = x_mm / 1000.0, y_mm / 1000.0, theta
        if second_team:
            x, y, yaw = -x, -y, math.atan2(math.sin(yaw + math.pi), math.cos(yaw + math.pi))
        pose = schemas.make("geometry_msgs/msg/Pose2D", x=x, y=y, theta=yaw)
        out.append(("position", _HL + "Position2D", schemas.make(_HL + "Position2D", header=schemas.header("map"),
                                                                  pose=pose, confidence=1.0)))
    if status.fallen in (0, 1):
        out.append(("robot_state", _HL + "RobotControlState", schemas.make(
            _HL + "RobotControlState", state=_FALLEN if status.fallen else _CONTROLLABLE)))
    bx, by = status.ball_mm
    if 0.0 <= status.ball_age_s <= BALL_SEEN_S and math.isfinite(bx) and math.isfinite(by):
        point = schemas.make("geometry_msgs/msg/Point", x=bx / 1000.0, y=by / 1000.0, z=0.0)
        out.append(("ball_relative", _HL + "BallRelative", schemas.make(
            _HL + "BallRelative", header=schemas.header(), ball_relative=point,
            confidence=max(0.1, 1.0 - status.ball_age_s / BALL_SEEN_S))))
    return out


class GameControllerMonitorSource(Source):
    """Starts a GameControllerMonitor and hands what it has to the hub twice a second."""

    name = "gc_monitor"

    def __init__(self, hub: Hub, gc_host: str, request_port: int = MONITOR_REQUEST_PORT,
                 listen_address: str = "0.0.0.0", data_port: int = MONITOR_DATA_PORT,
                 forward_port: int = MONITOR_FORWARD_PORT) -> None:
        super().__init__()
        self.hub = hub
        self.gc_host = gc_host
        self.ports = (request_port, data_port, forward_port)
        self.listen_address = listen_address
        self.monitor: GameControllerMonitor | None = None
        self.published = 0
        self._task: asyncio.Task[None] | None = None

    async def start(self) -> None:
        request_port, data_port, forward_port = self.ports
        try:
            self.monitor = GameControllerMonitor(self.gc_host, request_port, self.listen_address, data_port,
                                                 forward_port).start()
        except OSError as exc:
            self.error = f"cannot listen for the GameController's monitor data: {exc}"
            raise SourceError(self.error) from exc
        self.error = ""
        self.running = True
        self._task = asyncio.create_task(self._run())

    async def stop(self) -> None:
        self.running = False
        task, self._task = self._task, None
        if task is not None:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
        monitor, self.monitor = self.monitor, None
        if monitor is not None:
            await asyncio.to_thread(monitor.stop)

    async def _run(self) -> None:
        while self.running:
            self.publish_now()
            await asyncio.sleep(PERIOD_S)

    def publish_now(self) -> None:
        if self.monitor is None:
            return
        truth = self.monitor.latest()
        now_mono, now = time.monotonic(), time.time()
        for (team, player), seen in sorted(self.monitor.robots().items()):
            if now_mono - seen.received > ROBOT_GONE_S:
                continue
            for topic, typename, msg in robot_messages(seen, truth):
                self.hub.publish(HubMessage(robot_id(team, player), topic, typename, now, msg, self.name))
                self.published += 1

    def status(self) -> dict[str, Any]:
        status = super().status()
        status.update(gc_host=self.gc_host, published=self.published)
        if self.monitor is not None:
            c = self.monitor.counts
            status.update(true_packets=c.true_packets, statuses=c.statuses, bad_packets=c.bad_packets,
                          robots=len(c.robots), requests_sent=self.monitor.requests_sent, last_error=c.last_error)
        return status
