"""The 3D robot view: a viser server on its own port showing each robot's URDF, driven by its joint_states.

The page embeds viser's own client (bundled in the wheel, works offline) in an iframe. Updating the
scene costs a few ms per robot, so joint angles are applied at most ``robot3d_max_hz`` times a second,
always with the newest joint_states.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from pathlib import Path
from typing import Any

import numpy as np

from server.config import RobotDescription, ServerConfig
from server.hub import Hub, HubMessage, Subscriber

log = logging.getLogger(__name__)
ROBOT_SPACING_M = 0.6
CAMERA_POSITION = (0.9, -0.9, 0.6)  # a kid-size robot (about 0.5 m) fills the view
CAMERA_LOOK_AT = (0.0, 0.0, 0.25)
GROUND_SIZE_M = 4.0


def package_resolver(description: RobotDescription) -> Any:
    """yourdfpy filename_handler: ``package://<pkg>/rest`` -> the folder configured for <pkg>, else next to the URDF."""
    import yourdfpy

    base = description.urdf.parent

    def handler(fname: str) -> str:
        if fname.startswith("package://"):
            package, _, rest = fname[len("package://"):].partition("/")
            folder = description.packages.get(package)
            if folder is not None:
                return str(Path(folder) / rest)
        return str(yourdfpy.filename_handler_magic(fname, dir=base))

    return handler


class RobotModel:
    """One robot in the scene: its URDF under ``/<robot>`` and the joint order viser expects."""

    def __init__(self, server: Any, robot: str, description: RobotDescription, index: int) -> None:
        import yourdfpy
        from viser.extras import ViserUrdf

        if not description.urdf.exists():
            raise FileNotFoundError(f"URDF of robot {robot!r} not found: {description.urdf}")
        urdf = yourdfpy.URDF.load(str(description.urdf), filename_handler=package_resolver(description))
        self.frame = server.scene.add_frame(f"/{robot}", position=(0.0, index * ROBOT_SPACING_M, 0.0),
                                            show_axes=False)
        self.view = ViserUrdf(server, urdf, root_node_name=f"/{robot}")
        self.joint_names = list(self.view.get_actuated_joint_names())
        self.cfg = np.zeros(len(self.joint_names))
        self._index = {name: i for i, name in enumerate(self.joint_names)}
        self.updates = 0

    def apply(self, names: list[str], positions: Any) -> int:
        """Sets the named joints (others keep their angle); returns how many joints the URDF knew."""
        known = 0
        for name, position in zip(names, positions, strict=False):
            i = self._index.get(name)
            if i is not None and np.isfinite(position):
                self.cfg[i] = position
                known += 1
        self.view.update_cfg(self.cfg)
        self.updates += 1
        return known


class Robot3DView:
    """Subscribes to every robot's joint_states (rate-limited in the hub) and moves the URDFs."""

    def __init__(self, hub: Hub, config: ServerConfig) -> None:
        self.hub = hub
        self.config = config
        self.port = config.robot3d_port
        self.server: Any = None
        self.robots: dict[str, RobotModel] = {}
        self.failed: dict[str, str] = {}
        self._task: asyncio.Task[None] | None = None
        self._sub: Subscriber | None = None

    async def start(self) -> None:
        import viser

        host = "127.0.0.1" if self.config.host in ("localhost", "127.0.0.1") else self.config.host
        self.server = await asyncio.to_thread(viser.ViserServer, host=host, port=self.port, verbose=False)
        self.port = self.server.get_port()
        self.server.initial_camera.position = CAMERA_POSITION
        self.server.initial_camera.look_at = CAMERA_LOOK_AT
        self.server.scene.world_axes.visible = False
        self.server.scene.add_grid("/ground", width=GROUND_SIZE_M, height=GROUND_SIZE_M, cell_size=0.1,
                                   section_size=0.5, plane="xy", shadow_opacity=0.2)
        # the view lives in a small dashboard panel: viser's own controls start folded to a rail on the right
        self.server.gui.configure_theme(control_width="small", show_logo=False, show_share_button=False)
        self.server.gui.main_panel.dock_right()
        self.server.gui.main_panel.minimize()
        self._sub = self.hub.subscribe("robot3d", maxlen=64)
        self._sub.subscribe("*", "joint_states", max_hz=self.config.robot3d_max_hz)
        self._task = asyncio.create_task(self._run())

    async def _run(self) -> None:
        assert self._sub is not None
        while True:
            await self._sub.wait()
            newest: dict[str, HubMessage] = {}
            for msg in self._sub.drain():
                newest[msg.robot] = msg
            for robot, msg in newest.items():
                try:
                    await asyncio.to_thread(self._update, robot, msg)
                except Exception as exc:  # a bad URDF or message must not stop the view of the others
                    if robot not in self.failed:
                        log.warning("3D view of %s: %s", robot, exc)
                    self.failed[robot] = str(exc)

    def _update(self, robot: str, msg: HubMessage) -> None:
        if robot in self.failed:
            return
        model = self.robots.get(robot)
        if model is None:
            model = RobotModel(self.server, robot, self.config.description_for(robot), len(self.robots))
            self.robots[robot] = model
        joints = msg.message
        model.apply(list(joints.name), joints.position)

    def status(self) -> dict[str, Any]:
        return {"port": self.port, "failed": dict(self.failed),
                "robots": {r: {"updates": m.updates, "joints": m.joint_names} for r, m in self.robots.items()}}

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(BaseException):
                await self._task
        if self._sub is not None:
            self._sub.close()
        if self.server is not None:
            await asyncio.to_thread(self.server.stop)
