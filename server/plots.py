"""Plots: the server feeds rerun with downsampled numbers (joints vs goals, IMU, loop rates) and the HCM and game
states as named lanes, all on one time axis.

rerun serves its web viewer from the wheel (offline) on ``plots_web_port`` and the data over gRPC on
``plots_grpc_port``; the page embeds the viewer in an iframe. Every numeric stream is thinned by the hub to
``plots_max_hz``; the state streams are few messages a second and taken whole, so a short state (FALLING) is
never thinned away, and only their changes are logged. rerun's own usage analytics: ``TELEMETRY_ENABLED`` is
forced off here; the SDK's analytics setting lives in rerun's config file (``rerun analytics disable``) and fails
harmlessly offline.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
from typing import Any

import schemas
from server.config import ServerConfig
from server.hub import Hub, HubMessage, Subscriber

log = logging.getLogger(__name__)
NUMERIC_TOPICS = ("joint_states", "motor_goals", "imu/data", "diagnostics")
STATE_TOPICS = ("robot_state", "gamestate")
_HCM_NAMES = {v: k for k, v in schemas.constants("humanoid_league_msgs/msg/RobotControlState").items()}
_GAME = schemas.constants("humanoid_league_msgs/msg/GameState")
_GAME_NAMES = {v: k.removeprefix("GAMESTATE_") for k, v in _GAME.items() if k.startswith("GAMESTATE_")}
_SECONDARY_NAMES = {v: k.removeprefix("STATE_") for k, v in _GAME.items()
                    if k.startswith("STATE_") and k != "STATE_NORMAL"}


def scalars_of(msg: HubMessage) -> dict[str, float]:
    """Entity path (under the robot) -> value, for the fields worth plotting."""
    m = msg.message
    out: dict[str, float] = {}
    if msg.topic == "joint_states":
        for name, position in zip(m.name, m.position, strict=False):
            out[f"joints/{name}/position"] = float(position)
    elif msg.topic == "motor_goals":
        if m.points:
            for name, position in zip(m.joint_names, m.points[-1].positions, strict=False):
                out[f"joints/{name}/goal"] = float(position)
    elif msg.topic == "imu/data":
        for axis in "xyz":
            out[f"imu/angular_velocity/{axis}"] = float(getattr(m.angular_velocity, axis))
            out[f"imu/linear_acceleration/{axis}"] = float(getattr(m.linear_acceleration, axis))
    elif msg.topic == "diagnostics":
        for status in m.status:
            node = status.name.rsplit("/", 1)[-1]
            for kv in status.values:
                if kv.key.startswith("rate_hz/"):
                    with contextlib.suppress(ValueError):
                        out[f"loop_rates/{node}/{kv.key[len('rate_hz/'):]}"] = float(kv.value)
    return out


def states_of(msg: HubMessage) -> dict[str, str]:
    """Entity path (under the robot) -> state name, for the lanes: HCM state, game state, penalized."""
    m = msg.message
    if msg.topic == "robot_state":
        return {"lanes/hcm": _HCM_NAMES.get(m.state, f"state {m.state}")}
    if msg.topic == "gamestate":
        game = _GAME_NAMES.get(m.game_state, f"state {m.game_state}")
        if m.secondary_state in _SECONDARY_NAMES:
            game += f" / {_SECONDARY_NAMES[m.secondary_state]}"
        return {"lanes/game": game, "lanes/penalized": "penalized" if m.penalized else "in play"}
    return {}


def blueprint(robots: list[str]) -> Any:
    """A tab per robot: joints (position vs goal), IMU, loop rates, and the HCM/game state lanes (one timeline)."""
    import rerun.blueprint as rrb

    return rrb.Blueprint(rrb.Tabs(*[
        rrb.Grid(
            rrb.TimeSeriesView(origin=f"/{robot}/joints", name="joints: position vs goal"),
            rrb.TimeSeriesView(origin=f"/{robot}/imu", name="IMU"),
            rrb.TimeSeriesView(origin=f"/{robot}/loop_rates", name="loop rates (Hz)"),
            rrb.StateTimelineView(origin=f"/{robot}/lanes", name="HCM state, game state, penalized"),
            name=robot,
        ) for robot in robots]), collapse_panels=True)


class PlotFeed:
    """A hub subscriber that logs scalars into one rerun recording served to the browser."""

    def __init__(self, hub: Hub, config: ServerConfig) -> None:
        self.hub = hub
        self.config = config
        self.logged = 0
        self.state_changes = 0
        self.robots: list[str] = []
        self._states: dict[str, str] = {}  # entity path -> the state last logged there
        self.rec: Any = None
        self._sub: Subscriber | None = None
        self._task: asyncio.Task[None] | None = None

    def urls(self) -> dict[str, int]:
        return {"web_port": self.config.plots_web_port, "grpc_port": self.config.plots_grpc_port}

    def status(self) -> dict[str, Any]:
        """What the viewer is fed: messages plotted so far, state changes logged, and the robots with a tab."""
        return {**self.urls(), "logged": self.logged, "state_changes": self.state_changes,
                "robots": list(self.robots)}

    async def start(self) -> None:
        os.environ["TELEMETRY_ENABLED"] = "false"
        import rerun as rr

        self.rec = rr.RecordingStream("pitchside")
        uri = rr.serve_grpc(grpc_port=self.config.plots_grpc_port, recording=self.rec, server_memory_limit="256MiB")
        rr.serve_web_viewer(web_port=self.config.plots_web_port, open_browser=False, connect_to=uri)
        self._sub = self.hub.subscribe("plots", maxlen=4096)
        for topic in NUMERIC_TOPICS:
            self._sub.subscribe("*", topic, max_hz=self.config.plots_max_hz)
        for topic in STATE_TOPICS:
            self._sub.subscribe("*", topic)
        self._task = asyncio.create_task(self._run())

    async def _run(self) -> None:
        import rerun as rr

        assert self._sub is not None
        while True:
            await self._sub.wait()
            for msg in self._sub.drain():
                try:
                    values = scalars_of(msg)
                    states = states_of(msg)
                except Exception as exc:  # undecodable input is counted by the hub, not plotted
                    log.debug("not plotted: %s", exc)
                    continue
                if msg.robot not in self.robots:
                    self.robots.append(msg.robot)
                    self.rec.send_blueprint(blueprint(self.robots))
                self.rec.set_time("time", timestamp=msg.stamp)
                for path, value in values.items():
                    self.rec.log(f"{msg.robot}/{path}", rr.Scalars(value))
                for path, state in states.items():
                    entity = f"{msg.robot}/{path}"
                    if self._states.get(entity) != state:
                        self._states[entity] = state
                        self.rec.log(entity, rr.StateChange(state=state))
                        self.state_changes += 1
                self.logged += 1

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(BaseException):
                await self._task
        if self._sub is not None:
            self._sub.close()
        if self.rec is not None:
            with contextlib.suppress(Exception):
                self.rec.disconnect()
