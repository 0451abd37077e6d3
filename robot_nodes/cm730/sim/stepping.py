"""Stepping MuJoCo without letting go of Python's GIL.

MuJoCo's Python binding releases the GIL around every ``mj_step`` call. Getting it back afterwards waits until the
thread holding it lets go: a thread running Python (the world's loop sending the robots' sensors, the perception
stand-ins) lets go only at Python's switch interval, 5 ms. The world's physics thread makes one or two calls per
4-10 ms of simulated time, so each could cost it up to 5 ms of waiting: measured with 8 robots and one other thread
running Python, 1.6 ms per 2 ms step instead of 0.32 (chunks of 5 steps; 6.0 ms for single steps), so the world
fell behind real time (bench/team.py's rtf_min_8) and a match in lockstep waited for its physics.

Here the same C function is called through ctypes.PyDLL, which keeps the GIL: the other threads wait for the step
(0.04 ms per robot), the step never waits for them. Where the library cannot be found (another MuJoCo build, a
platform whose library is named otherwise) the binding's call is used, with its waits. One difference remains: a
MuJoCo error, which the binding raises as ``mujoco.FatalError``, cannot cross ctypes and ends the process (the
launcher starts it again); the world had stopped stepping after one either way.
"""

from __future__ import annotations

import ctypes
import logging
from collections.abc import Callable
from pathlib import Path

import mujoco

log = logging.getLogger(__name__)

Step = Callable[[mujoco.MjModel, mujoco.MjData, int], None]


def _binding_step(model: mujoco.MjModel, data: mujoco.MjData, n: int) -> None:
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
        return _binding_step
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
