"""Cost of one animation step (sample 20 joint curves, build and encode the Animation message) at 100 Hz.

    python bench/animation_step.py [--steps 5000]

Uses the real Bit-Bots stand-up file from tests/data; the baseline is building and encoding the same
message with constant positions, so the ratio shows what the curves themselves add.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np

import schemas
from robot_nodes.runtime import header
from schemas.messages import Animation
from schemas.std import JointTrajectory, JointTrajectoryPoint
from wire.animation import AnimationPlayer, load_animation

FILE = Path(__file__).resolve().parents[1] / "tests" / "data" / "animations" / "wolfgang_stand_up_back.json"


def encode_step(names: list[str], positions: np.ndarray) -> bytes:
    point = schemas.make(JointTrajectoryPoint, positions=positions, effort=[])
    trajectory = schemas.make(JointTrajectory, header=header(), joint_names=names,
                              points=[point])
    msg = schemas.make(Animation, header=header(), first=False, last=False, hcm=True,
                       position=trajectory)
    return schemas.encode(msg)


def timed(fn: object, steps: int) -> list[float]:
    out = []
    for i in range(steps):
        t0 = time.perf_counter()
        fn(i)  # type: ignore[operator]
        out.append((time.perf_counter() - t0) * 1e6)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=5000)
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.steps = 200
    anim = load_animation(FILE)
    player = AnimationPlayer(anim, dict.fromkeys(anim.joints, 0.0))
    names = list(player.joint_names)
    constant = np.zeros(len(names))
    dt = player.duration / args.steps

    sample = timed(lambda i: player.positions(i * dt), args.steps)
    step = timed(lambda i: encode_step(names, player.positions(i * dt)), args.steps)
    baseline = timed(lambda i: encode_step(names, constant), args.steps)
    p50_sample, p50_step, p50_base = (statistics.median(x) for x in (sample, step, baseline))
    p99_step = float(np.percentile(step, 99))
    core_at_100hz = p50_step * 100 / 1e6 * 100
    print(f"{len(names)} joints, {args.steps} steps over {player.duration:.2f} s of {FILE.name}")
    print(f"sample curves      p50 {p50_sample:7.1f} us")
    print(f"step (sample+msg)  p50 {p50_step:7.1f} us   p99 {p99_step:7.1f} us")
    print(f"baseline (msg)     p50 {p50_base:7.1f} us   ratio step/baseline {p50_step / p50_base:.2f}")
    print(f"share of one core at 100 Hz: {core_at_100hz:.2f} %")
    print(f"RESULT animation_step joints={len(names)} sample_p50_us={p50_sample:.1f} step_p50_us={p50_step:.1f} "
          f"step_p99_us={p99_step:.1f} baseline_p50_us={p50_base:.1f} ratio={p50_step / p50_base:.2f} "
          f"core_pct_at_100hz={core_at_100hz:.2f}")


if __name__ == "__main__":
    main()
