"""The 3D robot view: a viser server showing each robot's URDF, driven by its joint_states.

viser listens on loopback only, on a port browsers refuse (server.loopback_ports), and closes any WebSocket a
browser opens to it directly: the page reaches it only through the dashboard (server.routers.robot3d), whose
checks and Content-Security-Policy then cover it. The panel embeds viser's own client (bundled in the wheel,
works offline) in an iframe. Updating the scene costs a few ms per robot, so joint angles are applied at most
``robot3d_max_hz`` times a second, always with the newest joint_states.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import tempfile
import threading
from pathlib import Path
from typing import Any

import numpy as np

from server.config import RobotDescription, ServerConfig
from server.hub import Hub, HubMessage, Subscriber
from server.loopback_ports import LOOPBACK, internal_port

log = logging.getLogger(__name__)
ROBOT_SPACING_M = 0.6
CAMERA_POSITION = (0.9, -0.9, 0.6)  # a kid-size robot (about 0.5 m) fills the view
CAMERA_LOOK_AT = (0.0, 0.0, 0.25)
GROUND_SIZE_M = 4.0
# keyframe ghosts (onion skin): faint copies of the robot, the selected keyframe stronger and in another colour
GHOST_RGBA = (0.35, 0.55, 0.95, 0.2)
GHOST_SELECTED_RGBA = (1.0, 0.55, 0.1, 0.5)
# which robot is which: a live robot in its URDF's own colours, a replayed one in the page's replay purple, the
# editor's preview as a translucent green ghost; each with its name above it (a replayed one's higher, so the labels
# of a live and a replayed robot never cover each other)
REPLAY_CSS = "#9b2fd1"  # the field view's replay colour (web/panels/field_view.js)
KIND_RGBA: dict[str, tuple[float, float, float, float] | None] = {
    "live": None, "replay": (*(int(REPLAY_CSS[i:i + 2], 16) / 255 for i in (1, 3, 5)), 1.0),  # type: ignore[dict-item]
    "preview": (0.1, 0.75, 0.45, 0.55)}
LABEL_HEIGHT_M = {"live": 0.78, "replay": 0.92, "preview": 0.85}


def kind_of(robot: str) -> str:
    """"replay" for a replayed robot (replay.<id>), else "live"; previews are made as such (Robot3DView)."""
    from wire import keys

    return "replay" if keys.is_replayed(robot) else "live"


def css_colour(rgba: tuple[float, float, float, float] | None) -> str:
    """The figure's colour as the page draws its legend ("" for the URDF's own colours)."""
    return "" if rgba is None else "#" + "".join(f"{round(255 * c):02x}" for c in rgba[:3])


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


OWN_DESCRIPTION = "robot_description"  # the robot's own URDF, latched (robot_state_publisher's topic)


def own_description(hub: Hub, config: ServerConfig, robot: str, folder: Path) -> RobotDescription | None:
    """The robot's own URDF from its robot_description topic, written into ``folder``, with the ``package://``
    folders configured (--package, the team profile's packages); None when it sent none or a URDF is given for this
    robot by name (--urdf ROBOT=PATH wins over what the robot says)."""
    if robot in config.descriptions:
        return None
    latest = hub.latest.get((robot, OWN_DESCRIPTION))
    if latest is None or latest.typename != "std_msgs/msg/String":
        return None
    path = folder / f"{robot}.urdf"
    path.write_text(own_text(latest))
    return RobotDescription(path, config.description_for(robot).packages)


def own_text(msg: HubMessage) -> str:
    return str(getattr(msg.message, "data", ""))


def load_urdf(description: RobotDescription) -> Any:
    """The robot's yourdfpy URDF with its meshes (the slow part of adding a robot: about 0.6 s for the minibot)."""
    import yourdfpy

    if not description.urdf.exists():
        raise FileNotFoundError(f"URDF not found: {description.urdf}")
    return yourdfpy.URDF.load(str(description.urdf), filename_handler=package_resolver(description))


def refuse_browsers(server: Any) -> None:
    """Closes every WebSocket to viser that a browser opened: only the dashboard's proxy may connect.

    viser accepts a WebSocket from any page. A browser always sends Origin with the handshake and no page can leave
    it out; the proxy sends none. So a handshake with an Origin is some page talking to viser directly, and it is
    closed before viser sends it a single message (viser starts sending only after its connect callbacks).
    """
    infra = server._websock_server  # viser's WebsockServer: ViserServer has no public accessor for it
    live = infra._live_connections  # client id -> websockets ServerConnection, whose .request is the handshake
    if not isinstance(live, dict):
        raise RuntimeError("this viser keeps its connections elsewhere: cannot refuse browsers, 3D view not started")

    async def check(client: Any) -> None:
        connection = live.get(client.client_id)
        if connection is None:
            log.error("3D view: a viser client without its connection; cannot check where it comes from")
            return
        request = getattr(connection, "request", None)
        if request is None or "Origin" in request.headers:
            await connection.close(1008, "the 3D view is served through the pitchside dashboard only")

    infra.on_client_connect(check)
    infra.disconnect_all_clients()  # any that connected before the check was in place


class RobotModel:
    """One robot in the scene: its URDF under ``/<robot>`` and the joint order viser expects.

    ``color`` (RGBA) draws every mesh in one colour and opacity (a ghost); ``urdf`` shares an already loaded
    yourdfpy URDF, which is safe only while its users are posed one after another (viser poses through it).
    """

    def __init__(self, server: Any, robot: str, description: RobotDescription, index: int, *,
                 color: tuple[float, float, float, float] | None = None, urdf: Any = None,
                 position: tuple[float, float, float] | None = None, label: str = "",
                 label_height_m: float = LABEL_HEIGHT_M["live"]) -> None:
        from viser.extras import ViserUrdf

        if urdf is None:
            urdf = load_urdf(description)
        self.name = f"/{robot}"
        self.frame = server.scene.add_frame(self.name, show_axes=False,
                                            position=position or (0.0, index * ROBOT_SPACING_M, 0.0))
        self.view = ViserUrdf(server, urdf, root_node_name=self.name, mesh_color_override=color)
        # the name above the robot, a child of its frame: it moves, hides and goes with it
        self.label = server.scene.add_label(f"{self.name}/label", label, position=(0.0, 0.0, label_height_m),
                                            anchor="bottom-center") if label else None
        self.joint_names = list(self.view.get_actuated_joint_names())
        self.cfg = np.zeros(len(self.joint_names))
        self._index = {name: i for i, name in enumerate(self.joint_names)}
        self.updates = 0
        self.color = color

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

    def tint(self, color: tuple[float, float, float, float]) -> None:
        """Recolours a ghost's meshes in place (no mesh is sent again)."""
        if color == self.color or self.color is None:
            return
        mesh: Any
        for mesh in self.view._meshes:  # ViserUrdf keeps its mesh handles here; viser has no public list
            mesh.color = color[:3]
            mesh.opacity = color[3]
        self.color = color

    def scene_angles(self) -> dict[str, float]:
        """Joint angles (rad) as the viser scene holds them, read back from each joint frame's rotation.

        A test of what the browser is sent, not of what we meant to send: R_frame = R_origin * R(axis, q).
        """
        from viser import transforms as tf

        out: dict[str, float] = {}
        # ViserUrdf pairs its joint frames with the URDF's joints in these two private lists
        for joint, handle in zip(self.view._joint_map_values, self.view._joint_frames, strict=False):
            if joint.type not in ("revolute", "continuous") or joint.name not in self._index:
                continue
            origin = joint.origin if joint.origin is not None else np.eye(4)
            r = origin[:3, :3].T @ tf.SO3(np.asarray(handle.wxyz, dtype=float)).as_matrix()
            axis = np.asarray(joint.axis if joint.axis is not None else (1.0, 0.0, 0.0), dtype=float)
            axis /= np.linalg.norm(axis)
            sin = 0.5 * float(axis @ np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]))
            cos = 0.5 * (float(np.trace(r)) - 1.0)
            out[joint.name] = math.atan2(sin, cos)
        return out

    @property
    def visible(self) -> bool:
        return bool(self.frame.visible)

    @visible.setter
    def visible(self, shown: bool) -> None:
        self.frame.visible = shown  # hides the URDF's meshes and the label, its children

    def remove(self) -> None:
        self.frame.remove()  # the URDF's frames, meshes and label are its children


class KeyframeGhosts:
    """A robot's animation shown as still ghosts, one per chosen keyframe, overlaid where its preview ghost moves.

    The ghosts are a pool: a new set of poses re-poses the ghosts already in the scene (a few ms each) and only
    adds or removes the difference; the URDF is loaded once and shared, so every pose change holds the lock.
    """

    def __init__(self, server: Any, robot: str, description: RobotDescription,
                 position: tuple[float, float, float]) -> None:
        self.server = server
        self.robot = robot
        self.description = description
        self.name = f"/{robot}_keyframes"
        self.root = server.scene.add_frame(self.name, position=position, show_axes=False)
        self.models: list[RobotModel] = []
        self.keyframes: list[int] = []
        self.selected = -1
        self._urdf: Any = None
        self._lock = threading.Lock()

    def show(self, poses: list[tuple[int, dict[str, float]]], selected: int) -> None:
        """poses: (keyframe index, joint -> rad) per ghost; the selected keyframe's ghost is drawn stronger."""
        with self._lock:
            if self._urdf is None and poses:
                self._urdf = load_urdf(self.description)
            while len(self.models) > len(poses):
                self.models.pop().remove()
            while len(self.models) < len(poses):
                self.models.append(RobotModel(self.server, f"{self.robot}_keyframes/ghost{len(self.models)}",
                                              self.description, 0, color=GHOST_RGBA, urdf=self._urdf,
                                              position=(0.0, 0.0, 0.0)))
            for model, (index, pose) in zip(self.models, poses, strict=True):
                model.cfg[:] = 0.0
                model.apply(list(pose), list(pose.values()))
                model.tint(GHOST_SELECTED_RGBA if index == selected else GHOST_RGBA)
            self.keyframes = [index for index, _ in poses]
            self.selected = selected

    def clear(self) -> int:
        with self._lock:
            removed = len(self.models)
            for model in self.models:
                model.remove()
            self.models.clear()
            self.keyframes = []
            return removed

    def scene_nodes(self) -> list[str]:
        """The ghost roots the viser scene holds under ours (whatever we think we added)."""
        prefix = f"{self.name}/"
        names = list(self.server.scene._handle_from_node_name)  # viser's node registry; no public listing exists
        return sorted(n for n in names if n.startswith(prefix) and "/" not in n[len(prefix):])

    def status(self) -> list[dict[str, Any]]:
        """Per ghost: its scene node, keyframe, colour and the joint angles (deg) the scene holds."""
        with self._lock:
            return [{"node": model.name, "keyframe": index, "selected": index == self.selected,
                     "opacity": model.color[3] if model.color else 1.0,
                     "exists": self.server.scene.get_handle_by_name(model.name) is not None,
                     "joints": {j: math.degrees(q) for j, q in model.scene_angles().items()}}
                    for model, index in zip(self.models, self.keyframes, strict=True)]


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
        self._unshown: dict[str, HubMessage] = {}  # robot -> its newest joint_states not yet applied
        self._posing = asyncio.Lock()
        self.previews: dict[str, RobotModel] = {}  # robot -> the editor's preview ghost, only while it plays
        self.hidden: set[str] = set()  # figures the user hid (kept for a figure that comes back, e.g. a preview)
        self._forgetting: set[asyncio.Task[None]] = set()
        self._own = tempfile.TemporaryDirectory(prefix="pitchside-urdf-")  # robots' own URDFs (robot_description)
        self.described: dict[str, str] = {}  # robot -> the URDF of its own it is shown with

    async def start(self) -> None:
        import viser

        port = internal_port(self.config.robot3d_port, "3D view (viser)")
        self.server = await asyncio.to_thread(viser.ViserServer, host=LOOPBACK, port=port, verbose=False)
        try:
            refuse_browsers(self.server)
        except Exception:
            await asyncio.to_thread(self.server.stop)
            raise
        self.port = self.server.get_port()  # viser takes the next port when this one was taken meanwhile
        self.server.initial_camera.position = CAMERA_POSITION
        self.server.initial_camera.look_at = CAMERA_LOOK_AT
        self.server.scene.world_axes.visible = False
        self.server.scene.add_grid("/ground", width=GROUND_SIZE_M, height=GROUND_SIZE_M, cell_size=0.1,
                                   section_size=0.5, plane="xy", shadow_opacity=0.2)
        # the view lives in a small dashboard panel: viser's own controls start folded to a rail on the right
        self.server.gui.configure_theme(control_width="small", show_logo=False, show_share_button=False)
        self.server.gui.main_panel.dock_right()
        self.server.gui.main_panel.minimize()
        loop = asyncio.get_running_loop()  # viser calls back on its own thread and loop
        self.server._websock_server.on_client_connect(
            lambda _connection: asyncio.run_coroutine_threadsafe(self._show_unshown(), loop) and None)
        self._sub = self.hub.subscribe("robot3d", maxlen=64)
        self.hub.on_robot_gone(self._on_gone)
        self._sub.subscribe("*", "joint_states", max_hz=self.config.robot3d_max_hz)
        self._sub.subscribe("*", OWN_DESCRIPTION)
        self._task = asyncio.create_task(self._run())

    async def _run(self) -> None:
        assert self._sub is not None
        while True:
            await self._sub.wait()
            newest: dict[str, HubMessage] = {}
            for msg in self._sub.drain():
                if msg.topic == OWN_DESCRIPTION:  # a URDF of its own, or a new one: the robot is shown anew with it
                    shown = msg.robot in self.robots or msg.robot in self.failed
                    if shown and self.described.get(msg.robot) != own_text(msg):
                        await self.forget(msg.robot)
                    continue
                newest[msg.robot] = msg
            for robot in newest:
                if robot not in self.robots and robot not in self.failed:
                    await self._guarded(robot, self._add_model, robot)  # loaded at once: a bad URDF is said at once
            self._unshown.update(newest)
            if self._viewers():  # nobody looks: posing the URDFs would cost the server most of its CPU
                await self._show_unshown()

    def _viewers(self) -> int:
        """Connections to viser (the dashboard's proxy, one per page showing the 3D view), counted from the moment
        they connect: viser's own client list waits for the page's first camera message."""
        return len(self.server._websock_server._live_connections)  # checked to be a dict by refuse_browsers

    async def _guarded(self, robot: str, work: Any, *args: Any) -> None:
        """Runs work in a thread; a bad URDF or message must not stop the view of the others."""
        try:
            await asyncio.to_thread(work, *args)
        except Exception as exc:
            if robot not in self.failed:
                log.warning("3D view of %s: %s", robot, exc)
            self.failed[robot] = str(exc)

    def _add_model(self, robot: str) -> None:
        kind = kind_of(robot)
        own = own_description(self.hub, self.config, robot, Path(self._own.name))
        if own is not None:
            self.described[robot] = own.urdf.read_text()
        else:
            self.described.pop(robot, None)
        model = RobotModel(self.server, robot, own or self.config.description_for(robot), len(self.robots),
                           color=KIND_RGBA[kind], label=robot, label_height_m=LABEL_HEIGHT_M[kind])
        model.visible = robot not in self.hidden
        self.robots[robot] = model

    def _on_gone(self, robot: str) -> None:
        task = asyncio.get_running_loop().create_task(self.forget(robot))
        self._forgetting.add(task)
        task.add_done_callback(self._forgetting.discard)

    async def forget(self, robot: str) -> None:
        """A robot gone for good (a closed replay's) leaves the scene."""
        async with self._posing:
            self._unshown.pop(robot, None)
            self.failed.pop(robot, None)
            model = self.robots.pop(robot, None)
            if model is not None:
                await asyncio.to_thread(model.remove)

    # -- the editor's preview ghost: in the scene only while a preview plays --------------------------------
    def add_preview(self, robot: str, position: tuple[float, float, float]) -> RobotModel:
        """Blocking (loads the URDF): the preview ghost of ``robot``, made or reused."""
        model = self.previews.get(robot)
        if model is None:
            name = f"{robot}_preview"
            model = RobotModel(self.server, name, self.config.description_for(robot), 0, position=position,
                               color=KIND_RGBA["preview"], label=f"{robot} preview",
                               label_height_m=LABEL_HEIGHT_M["preview"])
            model.visible = name not in self.hidden
            self.previews[robot] = model
        return model

    def remove_preview(self, robot: str) -> None:
        model = self.previews.pop(robot, None)
        if model is not None:
            model.remove()

    def figures(self) -> list[dict[str, Any]]:
        """Every robot figure in the scene: its name, kind (live, replay, preview), colour and whether it is shown."""
        out = [{"name": robot, "kind": kind_of(robot), "visible": model.visible,
                "color": css_colour(KIND_RGBA[kind_of(robot)])} for robot, model in sorted(self.robots.items())]
        out += [{"name": model.name.lstrip("/"), "kind": "preview", "visible": model.visible,
                 "color": css_colour(KIND_RGBA["preview"])} for _, model in sorted(self.previews.items())]
        return out

    def set_visible(self, name: str, visible: bool) -> bool:
        """Shows or hides a figure by name; False if no such figure is in the scene (the choice is kept anyway)."""
        (self.hidden.discard if visible else self.hidden.add)(name)
        models = {**self.robots, **{m.name.lstrip("/"): m for m in self.previews.values()}}
        model = models.get(name)
        if model is None:
            return False
        model.visible = visible
        return True

    async def _show_unshown(self) -> None:
        """Poses each robot as its newest joint_states say (also what a viewer that just connected sees first)."""
        async with self._posing:  # the models share URDFs, which pose one robot at a time
            unshown, self._unshown = self._unshown, {}
            for robot, msg in unshown.items():
                await self._guarded(robot, self._update, robot, msg)

    def _update(self, robot: str, msg: HubMessage) -> None:
        model = self.robots.get(robot)
        if model is not None and robot not in self.failed:
            model.apply(list(msg.message.name), msg.message.position)

    def status(self) -> dict[str, Any]:
        viewers = self._viewers() if self.server is not None else 0  # pages showing the scene
        return {"port": self.port, "viewers": viewers, "failed": dict(self.failed),
                "robots": {r: {"updates": m.updates, "joints": m.joint_names} for r, m in self.robots.items()},
                "figures": self.figures() if self.server is not None else []}

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(BaseException):
                await self._task
        if self._sub is not None:
            self._sub.close()
        if self.server is not None:
            await asyncio.to_thread(self.server.stop)
        self._own.cleanup()
