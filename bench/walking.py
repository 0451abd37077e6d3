"""Cost of the walk engine: compute time per cycle, and CPU of the walking process at 100 Hz and 500 Hz.

    python bench/walking.py [--cycles 5000] [--seconds 6]

Part 1 times WalkEngine.update (gait, IK of both legs, leg odometry from measured joints) in this process,
walking forward with a mixed command; the baseline is building and encoding the walk_motor_goals message the
node sends every cycle, so the ratio says what the engine adds to the messaging it needs anyway.
Part 2 starts `python -m robot_nodes.walking` as its own process on a Zenoh router in this process, feeds it
what the robot would (robot_state CONTROLLABLE, cmd_vel, joint_states and imu/data at the engine's rate) and
reads its CPU % (psutil, 100 % = one core) while it walks.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np
import psutil

import schemas
from robot_nodes.runtime import BusConfig, Node, header, open_router
from robot_nodes.walking import WalkEngine
from robot_nodes.walking.engine import WalkOutput
from schemas.messages import RobotControlState
from schemas.std import Imu, JointState, JointTrajectory, JointTrajectoryPoint, Quaternion, Twist, Vector3
from tests.support import free_port

REPO = Path(__file__).resolve().parents[1]


def encode_goals(out: WalkOutput) -> bytes:
    point = schemas.make(JointTrajectoryPoint, positions=np.asarray(out.positions))
    return schemas.encode(schemas.make(JointTrajectory, header=header(),
                                       joint_names=list(out.names), points=[point]))


def engine_cycles(cycles: int) -> tuple[list[float], list[float], list[float]]:
    engine = WalkEngine()
    engine.set_command(0.1, 0.03, 0.2)
    present = engine.stance_goals()
    out = engine.update(0.01, present)
    for _ in range(300):  # through the start into steady walking
        out = engine.update(0.01, dict(zip(out.names, out.positions, strict=True)))
    times, cpu, base = [], [], []
    for _ in range(cycles):
        present = dict(zip(out.names, out.positions, strict=True))
        engine.set_imu(0.05, 0.0, 0.0, 0.0, 0.0)
        c0 = time.thread_time_ns()
        t0 = time.perf_counter()
        out = engine.update(0.01, present)
        t1 = time.perf_counter()
        c1 = time.thread_time_ns()
        encode_goals(out)
        t2 = time.perf_counter()
        times.append((t1 - t0) * 1e6)
        cpu.append((c1 - c0) / 1e3)
        base.append((t2 - t1) * 1e6)
    return times, cpu, base


class Feeder(Node):
    """Stands in for cm730 and the HCM: joint_states, imu/data and robot_state, plus the walk command."""

    name = "walk_bench_feeder"

    def setup(self) -> None:
        self.joints = self.publisher("joint_states")
        self.imu = self.publisher("imu/data")
        self.state = self.publisher("robot_state")
        self.cmd = self.publisher("cmd_vel")
        self.goals = 0
        self.active = False
        self.names = list(WalkEngine().stance_goals())
        self.positions = np.array(list(WalkEngine().stance_goals().values()))
        self.subscribe("walk_motor_goals", self.on_goals)
        self.subscribe("walking_active", self.on_active)
        self.timer(self.command, rate_hz=10.0)
        self.sensor_timer = self.timer(self.sensors, rate_hz=100.0)

    def on_goals(self, msg: object) -> None:
        self.goals += 1
        self.positions = np.asarray(msg.points[0].positions)  # type: ignore[attr-defined]

    def on_active(self, msg: object) -> None:
        self.active = bool(msg.data)  # type: ignore[attr-defined]

    def command(self) -> None:
        self.state.publish(schemas.make(RobotControlState, state=0))
        self.cmd.publish(schemas.make(Twist,
                                      linear=schemas.make(Vector3, x=0.1, y=0.03),
                                      angular=schemas.make(Vector3, z=0.2)))

    def sensors(self) -> None:
        self.joints.publish(schemas.make(JointState, header=header(), name=self.names,
                                         position=self.positions, velocity=np.zeros(len(self.names)),
                                         effort=np.zeros(len(self.names))))
        self.imu.publish(schemas.make(Imu, header=header("imu_frame"),
                                      orientation=schemas.make(Quaternion, w=1.0)))


def process_cpu(endpoint: str, hz: float, seconds: float) -> tuple[float, float]:
    """(CPU % of the walking process, walk_motor_goals per second it sent) while walking at hz."""
    feeder = Feeder("robot1", BusConfig(connect=[endpoint]))
    feeder.sensor_timer.set_rate(hz)
    feeder.start()
    proc = subprocess.Popen([sys.executable, "-m", "robot_nodes.walking", "--connect", endpoint,
                             "--set", f"rate_hz={hz}", "--log-level", "WARNING"], cwd=REPO)
    try:
        deadline = time.monotonic() + 30.0
        while not feeder.active:
            if time.monotonic() > deadline or proc.poll() is not None:
                raise SystemExit("the walking process did not start walking")
            time.sleep(0.05)
        time.sleep(1.0)  # through the start into steady walking
        ps = psutil.Process(proc.pid)
        ps.cpu_percent(None)
        goals0, t0 = feeder.goals, time.monotonic()
        time.sleep(seconds)
        cpu = ps.cpu_percent(None)
        rate = (feeder.goals - goals0) / (time.monotonic() - t0)
        return cpu, rate
    finally:
        proc.terminate()
        proc.wait(10)
        feeder.shutdown()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cycles", type=int, default=5000)
    parser.add_argument("--seconds", type=float, default=6.0, help="CPU measuring window per rate")
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.cycles, args.seconds = 200, 1.0

    times, cpu, base = engine_cycles(args.cycles)
    p50, p99 = statistics.median(times), float(np.percentile(times, 99))
    cpu50, cpu99 = statistics.median(cpu), float(np.percentile(cpu, 99))
    base50 = statistics.median(base)
    print(f"load average {' '.join(f'{v:.1f}' for v in psutil.getloadavg())} on {psutil.cpu_count()} cores "
          "(wall-clock p99 includes time the OS gave to others; thread CPU time does not)")
    print(f"engine cycle (gait + IK + leg odometry)  p50 {p50:7.1f} us   p99 {p99:7.1f} us   (wall clock)")
    print(f"engine cycle, thread CPU time           p50 {cpu50:7.1f} us   p99 {cpu99:7.1f} us")
    print(f"baseline (encode walk_motor_goals)       p50 {base50:7.1f} us   ratio engine/baseline "
          f"{p50 / base50:.2f}")
    print(f"share of one core for the engine alone: {p50 * 100 / 1e4:.2f} % at 100 Hz, "
          f"{p50 * 500 / 1e4:.2f} % at 500 Hz")

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = open_router([endpoint])
    try:
        cpu100, rate100 = process_cpu(endpoint, 100.0, args.seconds)
        print(f"walking process at 100 Hz: {cpu100:5.1f} % CPU, {rate100:6.1f} goals/s")
        cpu500, rate500 = process_cpu(endpoint, 500.0, args.seconds)
        print(f"walking process at 500 Hz: {cpu500:5.1f} % CPU, {rate500:6.1f} goals/s")
    finally:
        router.close()
    print(f"RESULT walking cycle_p50_us={p50:.1f} cycle_p99_us={p99:.1f} cpu_pct_100hz={cpu100:.1f} "
          f"cpu_pct_500hz={cpu500:.1f} cycle_cpu_p50_us={cpu50:.1f} cycle_cpu_p99_us={cpu99:.1f} "
          f"goals_per_s_100hz={rate100:.1f} goals_per_s_500hz={rate500:.1f} "
          f"baseline_encode_p50_us={base50:.1f} ratio={p50 / base50:.2f}")


if __name__ == "__main__":
    main()
