"""A world in lockstep steps its physics without letting go of the GIL, exactly as MuJoCo's binding steps."""

from __future__ import annotations

import sys
import threading
import time

import mujoco
import numpy as np

from robot_nodes.runtime import BusConfig
from robot_nodes.sim import SimWorld
from robot_nodes.sim.__main__ import serve_world
from robot_nodes.sim.stepping import step_holding_gil, step_releasing_gil
from tests.waiting import wait_for


def test_stepping_holding_the_gil_gives_the_bindings_result_bit_for_bit() -> None:
    world = SimWorld(n_robots=2)
    world.robots[0].apply_push((20.0, 5.0, 0.0), 0.05)  # something moves: contacts change from step to step
    world.step(50)
    twin = mujoco.MjData(world.model)
    mujoco.mj_copyData(twin, world.model, world.data)
    step_holding_gil(world.model, world.data, 200)
    step_releasing_gil(world.model, twin, 200)
    assert world.data.time == twin.time
    assert np.array_equal(world.data.qpos, twin.qpos) and np.array_equal(world.data.qvel, twin.qvel)
    assert world.data.time > 0.2 and np.abs(world.data.qvel).max() > 0.01  # it moved: a comparison that could fail


def test_no_other_python_thread_runs_while_the_world_steps_and_with_the_binding_one_would() -> None:
    """What makes the physics thread immune to Python's switch interval: nobody else runs Python while it steps,
    so it has no GIL to wait for afterwards. MuJoCo's own binding lets another thread in during its steps (on a
    loaded machine not in every call: the other thread must get a core meanwhile)."""
    world = SimWorld(n_robots=2)
    count = [0]
    stop = threading.Event()

    def spin() -> None:
        while not stop.is_set():
            count[0] += 1

    interval = sys.getswitchinterval()
    sys.setswitchinterval(1.0)  # no forced switch during the held call: only a released GIL lets the spinner in
    spinner = threading.Thread(target=spin)
    try:
        spinner.start()
        time.sleep(0.01)  # the spinner runs; this thread gets the GIL back at the spinner's next forced switch
        before = count[0]
        step_holding_gil(world.model, world.data, 5)
        held = count[0] - before
        released, deadline = 0, time.monotonic() + 10.0
        while released == 0 and time.monotonic() < deadline:
            before = count[0]
            step_releasing_gil(world.model, world.data, 20)
            released = count[0] - before
    finally:
        stop.set()
        spinner.join()
        sys.setswitchinterval(interval)
    assert held == 0
    assert released > 0


def test_a_world_in_lockstep_holds_the_gil_and_a_free_running_one_lets_go(bus: BusConfig) -> None:
    """In lockstep the physics is on every tick's critical path; free-running, the world's loop and cameras need the
    other core while it steps (robot_nodes/sim/stepping.py)."""
    for sim_time, lockstep, held in ((True, True, True), (True, False, False), (False, False, False)):
        world = SimWorld(n_robots=1)
        served = serve_world(world, bus, sim_time=sim_time, lockstep=lockstep, cameras=0)
        try:
            assert world.hold_gil is held
            wait_for(lambda: world.time > 0.05, 10.0, what="the world steps")  # noqa: B023 (used at once)
        finally:
            served.close()
