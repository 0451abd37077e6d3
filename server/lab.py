"""Lab tools the control API keeps between requests: held teleop commands, the editor's animation goal, previews.

One ``LabTools`` per app, made on first use and kept in ``state.lab`` (the app's lifespan stops it with the
views, so the teleop loops end with a zero command and the goals are cancelled on shutdown). Everything that
sends goes through the server's one Zenoh session (``ZenohLink``), which match mode refuses.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import math
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

import schemas
from schemas.messages import PlayAnimationGoal
from schemas.std import Twist, Vector3
from server.state import ServerState
from wire import keys
from wire.actions import ActionClient, ClientGoal
from wire.animation import Animation, AnimationPlayer, mirror_signs_from_axes
from wire.ros2.attachment import AttachmentStamper
from wire.ros2.liveliness import NodeInfo
from wire.ros2.robots import next_node_id, publisher_entity, robot_namespace

if TYPE_CHECKING:
    from server.robot3d import Robot3DView

TELEOP_HZ = 10.0
TELEOP_HOLD_S = 0.5  # a command not refreshed for this long stops the robot
PREVIEW_HZ = 20.0
PREVIEW_HOLD_S = 1.0  # the preview ghost shows the animation's last pose this long, then leaves the scene
GOAL_TIMEOUT_S = 10.0  # a busy laptop (a match, a browser, the simulation) answers late; an error would be worse
DASHBOARD_NODE = "pitchside_dashboard"  # the node name the dashboard's commands come from on the ROS 2 graph


@dataclass(slots=True)
class JointLimits:
    """Revolute joints of a URDF in file order: limits (rad) and top speed (rad/s)."""

    names: list[str] = field(default_factory=list)
    limits: dict[str, tuple[float, float]] = field(default_factory=dict)
    velocity: dict[str, float] = field(default_factory=dict)


def urdf_joint_limits(path: Path) -> JointLimits:
    """Reads the movable joints of a URDF with the standard library: no meshes needed."""
    out = JointLimits()
    root = ET.parse(path).getroot()
    for joint in root.iter("joint"):
        if joint.get("type") not in ("revolute", "continuous", "prismatic"):
            continue
        name = joint.get("name") or ""
        out.names.append(name)
        limit = joint.find("limit")
        if limit is None:
            continue
        if joint.get("type") != "continuous" and limit.get("lower") is not None and limit.get("upper") is not None:
            out.limits[name] = (float(limit.get("lower", 0)), float(limit.get("upper", 0)))
        if limit.get("velocity"):
            out.velocity[name] = float(limit.get("velocity", 0))
    return out


def urdf_mirror_signs(path: Path) -> dict[str, float]:
    """Mirror signs of the robot's joints from its URDF's axes (wire.animation.editing explains the rule),
    so mirror is right for any robot the server is given, not only for Bit-Bots' axis conventions."""
    return dict(_mirror_signs(str(path), path.stat().st_mtime))


@functools.lru_cache(maxsize=8)
def _mirror_signs(path: str, mtime: float) -> dict[str, float]:
    import yourdfpy

    urdf = yourdfpy.URDF.load(path, load_meshes=False, build_scene_graph=True)
    axes = {}
    for joint in urdf.robot.joints:
        if joint.type in ("revolute", "continuous"):
            rotation = urdf.get_transform(joint.child, urdf.base_link)[:3, :3]  # zero pose, in the base frame
            axis = joint.axis if joint.axis is not None else (1.0, 0.0, 0.0)
            axes[joint.name] = rotation @ np.asarray(axis, dtype=float)
    return mirror_signs_from_axes(axes)


@dataclass(slots=True)
class TeleopCommand:
    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    until: float = 0.0
    task: asyncio.Task[None] | None = None
    sent: int = 0


class LabTools:
    """What lives between lab requests; one per app."""

    def __init__(self, state: ServerState) -> None:
        self.state = state
        self._publishers: dict[tuple[str, str], tuple[Any, AttachmentStamper]] = {}
        self.teleop: dict[str, TeleopCommand] = {}
        self._clients: dict[str, ActionClient] = {}
        self.goals: dict[str, ClientGoal] = {}
        self._previews: dict[str, Any] = {}
        self._preview_tasks: dict[str, asyncio.Task[None]] = {}
        self._ghost_slots: dict[str, tuple[float, float, float]] = {}  # robot -> where its ghosts stand
        self._keyframe_ghosts: dict[str, Any] = {}  # robot -> KeyframeGhosts
        self.animation_folders: dict[str, tuple[float, Path, str]] = {}  # robot -> (when asked, folder, how found)

    # -- publishing ---------------------------------------------------------------------------------
    def publish(self, robot: str, topic: str, msg: schemas.Message) -> None:
        """Blocking on first use (opens the session): call from a worker thread."""
        key = (robot, topic)
        found = self._publishers.get(key)
        if found is None:
            session = self.state.link.session()
            # the dashboard's publisher as a ROS 2 node's: its samples carry rmw_zenoh's attachment
            node_id = next_node_id()
            entity = publisher_entity(str(session.zid()), robot, DASHBOARD_NODE, topic, node_id, node_id + 1,
                                      keys.domain_id())
            found = self._publishers[key] = (session.declare_publisher(keys.topic_key(robot, topic)),
                                             AttachmentStamper(entity.gid))
        pub, stamp = found
        pub.put(schemas.encode(msg), attachment=stamp.next())

    # -- teleop -------------------------------------------------------------------------------------
    async def drive(self, robot: str, x: float, y: float, yaw: float, hold_s: float = TELEOP_HOLD_S) -> TeleopCommand:
        """Holds the command for hold_s (refresh it to keep going); the loop sends it at TELEOP_HZ, then zero."""
        await asyncio.to_thread(self.state.link.session)  # opening may block; refuse in match mode here
        cmd = self.teleop.setdefault(robot, TeleopCommand())
        cmd.x, cmd.y, cmd.yaw = x, y, yaw
        cmd.until = time.monotonic() + hold_s
        if cmd.task is None or cmd.task.done():
            cmd.task = asyncio.create_task(self._teleop_loop(robot, cmd))
        return cmd

    async def halt(self, robot: str) -> None:
        cmd = self.teleop.get(robot)
        if cmd is not None:
            cmd.until = 0.0
            if cmd.task is not None:
                with contextlib.suppress(BaseException):
                    await cmd.task
        else:
            await asyncio.to_thread(self.publish, robot, "cmd_vel", twist(0.0, 0.0, 0.0))

    async def _teleop_loop(self, robot: str, cmd: TeleopCommand) -> None:
        try:
            while time.monotonic() < cmd.until:
                self.publish(robot, "cmd_vel", twist(cmd.x, cmd.y, cmd.yaw))
                cmd.sent += 1
                await asyncio.sleep(1.0 / TELEOP_HZ)
        finally:
            for _ in range(3):  # zero on release or timeout, sent more than once (no acknowledgement)
                with contextlib.suppress(Exception):
                    self.publish(robot, "cmd_vel", twist(0.0, 0.0, 0.0))
            cmd.x = cmd.y = cmd.yaw = 0.0

    # -- animation goals ----------------------------------------------------------------------------
    def play(self, robot: str, name: str, retry_s: float = 5.0) -> ClientGoal:
        """Sends PlayAnimation (blocking); retries while the HCM's own animation (e.g. walkready) runs."""
        client = self._clients.get(robot)
        if client is None:
            # on the ROS 2 graph as the node the dashboard's other commands come from
            node = NodeInfo(keys.domain_id(), robot_namespace(robot), DASHBOARD_NODE)
            client = self._clients[robot] = ActionClient(self.state.link.session(), robot, "animation", node=node)
        goal = PlayAnimationGoal(animation=name, hcm=False)
        deadline = time.monotonic() + retry_s
        while True:
            handle = client.send_goal(goal, timeout=GOAL_TIMEOUT_S)
            handle.wait_accepted(GOAL_TIMEOUT_S)
            if handle.accepted or "HCM animation" not in (handle.reason or "") or time.monotonic() > deadline:
                break
            time.sleep(0.2)
        if handle.accepted:
            self.goals[robot] = handle
        return handle

    def cancel(self, robot: str) -> bool:
        handle = self.goals.pop(robot, None)
        if handle is None or handle.done:
            return False
        return handle.cancel(timeout=GOAL_TIMEOUT_S)

    # -- 3D preview ---------------------------------------------------------------------------------
    def _view(self) -> Robot3DView:
        from server.robot3d import Robot3DView  # viser: loaded only with the 3D view on

        view = self.state.robot3d
        if not isinstance(view, Robot3DView) or view.server is None:
            raise RuntimeError("the 3D view is off (start the server with --robot3d)")
        return view

    def _ghost_slot(self, robot: str, view: Any) -> tuple[float, float, float]:
        """Where a robot's preview and keyframe ghosts stand: one place per robot, beside the real robots."""
        from server.robot3d import ROBOT_SPACING_M

        slot = self._ghost_slots.get(robot)
        if slot is None:
            slot = self._ghost_slots[robot] = (0.0, (len(view.robots) + 1 + len(self._ghost_slots)) * ROBOT_SPACING_M,
                                               0.0)
        return slot

    async def preview(self, robot: str, anim: Animation, start: dict[str, float] | None) -> float:
        """Plays the animation on a ghost robot in the 3D view; the real robot does not move."""
        view = self._view()
        old = self._preview_tasks.pop(robot, None)
        if old is not None:
            old.cancel()
        ghost = await asyncio.to_thread(view.add_preview, robot, self._ghost_slot(robot, view))
        self._previews[robot] = ghost
        player = AnimationPlayer(anim, start)
        self._preview_tasks[robot] = asyncio.create_task(self._preview_loop(robot, ghost, player))
        return float(player.duration)

    async def show_keyframes(self, robot: str, anim: Animation, keyframes: list[int], selected: int,
                             start: dict[str, float] | None) -> list[int]:
        """Still ghosts of the chosen keyframes, where the preview ghost moves; replaces the ones shown before.

        Each ghost is posed as the robot would be when its keyframe's duration ends: the keyframe's goals, and for
        joints the keyframe leaves out, the animation's curve at that moment (or the measured start pose).
        """
        view = self._view()
        from server.robot3d import KeyframeGhosts

        ghosts = self._keyframe_ghosts.get(robot)
        if ghosts is None:
            ghosts = self._keyframe_ghosts[robot] = KeyframeGhosts(
                view.server, robot, self.state.config.description_for(robot), self._ghost_slot(robot, view))
        chosen = sorted({k for k in keyframes if 0 <= k < len(anim.keyframes)})
        poses: list[tuple[int, dict[str, float]]] = []
        if chosen:
            player = AnimationPlayer(anim, start)
            for k in chosen:
                pose = dict(start or {})
                pose.update(player.goals_at(player.keyframe_times[k]))
                poses.append((k, pose))
        await asyncio.to_thread(ghosts.show, poses, selected)
        return chosen

    async def clear_keyframes(self, robot: str) -> int:
        ghosts = self._keyframe_ghosts.get(robot)
        return 0 if ghosts is None else int(await asyncio.to_thread(ghosts.clear))

    async def _preview_loop(self, robot: str, ghost: Any, player: AnimationPlayer) -> None:
        """Plays the preview on the ghost, holds its last pose a moment, then takes the ghost out of the scene: a
        preview robot is there only while it previews (a new preview of the same robot takes over the ghost)."""
        t0 = time.monotonic()
        while True:
            t = min(time.monotonic() - t0, player.duration)
            await asyncio.to_thread(ghost.apply, list(player.joint_names), player.positions(t))
            if t >= player.duration:
                break
            await asyncio.sleep(1.0 / PREVIEW_HZ)
        await asyncio.sleep(PREVIEW_HOLD_S)
        if self._preview_tasks.get(robot) is asyncio.current_task():
            del self._preview_tasks[robot]
            await asyncio.to_thread(self._view().remove_preview, robot)

    def keyframe_status(self, robot: str) -> dict[str, Any]:
        """The keyframe ghosts (with the joint angles the scene holds) and the ghost nodes in the scene."""
        ghosts = self._keyframe_ghosts.get(robot)
        if ghosts is None:
            return {"ghosts": [], "scene_nodes": []}
        return {"ghosts": ghosts.status(), "scene_nodes": ghosts.scene_nodes()}

    def preview_updates(self, robot: str) -> int:
        ghost = self._previews.get(robot)
        return int(ghost.updates) if ghost is not None else 0

    # -- lifespan -----------------------------------------------------------------------------------
    async def stop(self) -> None:
        for task in self._preview_tasks.values():
            task.cancel()
        for cmd in self.teleop.values():
            cmd.until = 0.0
        for cmd in self.teleop.values():
            if cmd.task is not None:
                with contextlib.suppress(BaseException):
                    await asyncio.wait_for(cmd.task, 2.0)
        for robot in list(self.goals):
            with contextlib.suppress(Exception):
                await asyncio.to_thread(self.cancel, robot)
        for client in self._clients.values():
            with contextlib.suppress(Exception):
                client.close()
        for pub, _ in self._publishers.values():
            with contextlib.suppress(Exception):
                pub.undeclare()


def twist(x: float, y: float, yaw: float) -> Twist:
    return Twist(linear=Vector3(x=x, y=y, z=0.0), angular=Vector3(x=0.0, y=0.0, z=yaw))


def lab_tools(state: ServerState) -> LabTools:
    """The app's LabTools, made on first use."""
    lab = state.lab
    if not isinstance(lab, LabTools):
        lab = state.lab = LabTools(state)
    return lab


def finite(value: float, what: str) -> float:
    if not math.isfinite(value):
        raise ValueError(f"{what} must be finite, got {value!r}")
    return value
