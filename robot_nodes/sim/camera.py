"""Offscreen rendering of a robot's head camera (MuJoCo with EGL on the CPU, OSMesa as the fallback)."""

from __future__ import annotations

import os

import numpy as np

from robot_nodes.sim.world import RobotHandle, SimWorld


class RenderError(RuntimeError):
    """No offscreen OpenGL is available for MuJoCo."""


def choose_gl_backend() -> str:
    """Sets MUJOCO_GL (egl unless the caller chose) before mujoco's renderer is first used."""
    return os.environ.setdefault("MUJOCO_GL", "egl")


class HeadCamera:
    """Renders what one robot's head camera sees; use from one thread only (the GL context lives there)."""

    def __init__(self, world: SimWorld, robot: RobotHandle, width: int = 320, height: int = 240) -> None:
        backend = choose_gl_backend()
        import mujoco

        gl = world.model.vis.global_
        if width > gl.offwidth or height > gl.offheight:
            raise RenderError(f"camera size {width}x{height} exceeds the offscreen buffer {gl.offwidth}x{gl.offheight}")
        try:
            self._renderer = mujoco.Renderer(world.model, height, width)
        except Exception as exc:  # EGL/OSMesa missing: say what to do instead of a GL stack trace
            raise RenderError(
                f"MuJoCo cannot render offscreen with MUJOCO_GL={backend} ({exc}); install EGL "
                "(libegl1) or OSMesa, or set MUJOCO_GL before importing mujoco") from exc
        self.world = world
        self.robot = robot
        self.width = width
        self.height = height

    def render(self, data: object | None = None) -> np.ndarray:
        """(height, width, 3) uint8 RGB, row 0 at the top; data defaults to the world's live data."""
        self._renderer.update_scene(data if data is not None else self.world.data, camera=self.robot.camera_id)
        return self._renderer.render()

    def close(self) -> None:
        self._renderer.close()
