"""Stepping MuJoCo with or without letting go of Python's GIL.

MuJoCo's Python binding releases the GIL around every ``mj_step`` call. Getting it back afterwards waits until the
thread holding it lets go: a thread running Python (the world's loop sending the robots' sensors, the perception
stand-ins) lets go only at Python's switch interval, 5 ms. Measured with 8 robots and one other thread running
Python: 1.6 ms per 2 ms step instead of 0.32 in chunks of 5 steps, 6.0 ms for single steps.

``step_holding_gil`` calls the same C function through ctypes.PyDLL, which keeps the GIL: the other threads wait for
the step (0.04 ms per robot), the step never waits for them. That is right for a world in lockstep, whose physics
is on every tick's critical path (the robots wait for the sensors it makes); a 4 v 4 match, the first 90 s after
READY, runs alternating on a machine whose speed drifted: mean real-time factor 0.578, 0.518, 0.532, 0.496 holding
the GIL against 0.515, 0.473, 0.454 letting go. A free-running world keeps the binding's call
(``step_releasing_gil``) with a short switch interval (runner.py): there its loop and camera threads need the other
core while the physics steps, and with the GIL held its cm730 nodes fell behind (8 robots with perception and a
camera, bench/world.py: 1430-1550 of 1600 sensor messages a second sent).

Where the library cannot be found (another MuJoCo build, a platform whose library is named otherwise) the binding's
call is used for both. One difference remains: a MuJoCo error, which the binding raises as ``mujoco.FatalError``,
cannot cross ctypes and ends the process (the launcher starts it again); the world had stopped stepping after one
either way.
"""

from __future__ import annotations

import ctypes
import logging
from collections.abc import Callable
from pathlib import Path

import mujoco

log = logging.getLogger(__name__)

Step = Callable[[mujoco.MjModel, mujoco.MjData, int], None]


def step_releasing_gil(model: mujoco.MjModel, data: mujoco.MjData, n: int) -> None:
    """``mujoco.mj_step(model, data, nstep=n)``: the binding's call, which lets go of the GIL while it steps."""
    mujoco.mj_step(model, data, nstep=n)


def _library() -> ctypes.PyDLL | None:
    """MuJoCo's C library as the binding loaded it (the file beside the package), or None."""
    folder = Path(mujoco.__file__).parent
    for pattern in (f"libmujoco.so.{mujoco.__version__}", "libmujoco.so*", "libmujoco*.dylib", "mujoco.dll"):
        for path in sorted(folder.glob(pattern)):
            try:
                return ctypes.PyDLL(str(path))
            except OSError:
                continue
    return None


def _holding_step() -> Step:
    library = _library()
    if library is None or not hasattr(mujoco.MjData, "_address"):
        log.info("MuJoCo steps through its binding (its C library was not found beside it): the physics thread may "
                 "wait for Python's GIL after each step")
        return step_releasing_gil
    c_step = library.mj_step
    c_step.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
    c_step.restype = None

    def step(model: mujoco.MjModel, data: mujoco.MjData, n: int) -> None:
        m, d = model._address, data._address
        for _ in range(n):
            c_step(m, d)

    return step


step_holding_gil: Step = _holding_step()
"""``mujoco.mj_step(model, data, nstep=n)``, keeping the GIL for the whole call."""
