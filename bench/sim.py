"""Simulation speed: real-time factor of one standing robot without and with a 10 Hz 320x240 head camera."""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from robot_nodes.sim import GroundTruthVision, SimWorld
from robot_nodes.sim.camera import HeadCamera

SIM_SECONDS = 20.0
CONTROL_PERIOD = 0.01  # s: a 100 Hz motion loop writes goals and reads the bus, as the cm730 node does


def run(with_camera: bool, sim_seconds: float = SIM_SECONDS) -> tuple[float, list[float]]:
    """(real-time factor, wall seconds per physics step of every control period)."""
    world = SimWorld(n_robots=1)
    robot = world.robots[0]
    camera = HeadCamera(world, robot, 320, 240) if with_camera else None
    vision = GroundTruthVision(world, robot, 320, 240) if with_camera else None
    steps = round(CONTROL_PERIOD / world.timestep)
    next_frame = 0.0
    per_step: list[float] = []
    names = ["HeadPan"]
    start = time.perf_counter()
    while world.time < sim_seconds:
        t0 = time.perf_counter()
        world.step(steps)
        per_step.append((time.perf_counter() - t0) / steps)
        robot.read()
        robot.write_goals(names, np.array([0.3 * np.sin(world.time)]))
        if camera is not None and vision is not None and world.time >= next_frame:
            camera.render()
            vision.observe()
            next_frame += 0.1
    wall = time.perf_counter() - start
    if camera is not None:
        camera.close()
    assert robot.uprightness() > 0.9, "the robot fell during the benchmark"
    return world.time / wall, per_step


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    sim_seconds = 0.5 if parser.parse_args().smoke else SIM_SECONDS
    rtf, per_step = run(with_camera=False, sim_seconds=sim_seconds)
    step_us = statistics.median(per_step) * 1e6
    print(f"physics only: {rtf:.1f}x real time, median {step_us:.1f} us per 2 ms step")
    rtf_camera, _ = run(with_camera=True, sim_seconds=sim_seconds)
    print(f"with 10 Hz 320x240 camera + detections: {rtf_camera:.1f}x real time")
    print("budget: rtf >= 5 without camera, >= 1.5 with camera")
    print(f"RESULT sim rtf={rtf:.2f} rtf_camera={rtf_camera:.2f} step_us={step_us:.1f}")


if __name__ == "__main__":
    main()
