"""What each node costs with nothing to do: CPU of its process while no data, command or goal reaches it.

    python bench/idle.py [--seconds 20]

Each robot node runs alone (``python -m <module>``) against a Zenoh router in this process, with nothing else on
the bus: no joint_states, no GameController, no browser. After it settled, the CPU time its process used over
``--seconds`` is its idle cost (% of one core). The baseline in the same run: the interpreter with the runtime
imported and a Zenoh session open, doing nothing (what any Python node process costs before its own work).

The HCM is the exception by design: it evaluates its state machine at 100 Hz whatever happens (the fall watch
cannot wait for data), so its line is the cost of watching.
"""

from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import psutil

import robots
from robot_nodes.catalog import NODES
from robot_nodes.runtime import open_router
from tests.support import REPO, free_port

IDLE_NODES = ["hcm", "animation", "walking", "pause", "speaker", "game_controller", "mitecom", "telemetry"]


def extra_arguments(name: str) -> list[str]:
    """Free ports for the nodes that listen on UDP; telemetry sends (its overview) under the development key."""
    if name == "game_controller":
        return ["--set", f"listen_port={free_port(socket.SOCK_DGRAM)}", "--set", "listen_address=127.0.0.1"]
    if name == "mitecom":
        return ["--set", f"port={free_port(socket.SOCK_DGRAM)}", "--set", "listen_address=127.0.0.1"]
    if name == "telemetry":
        return ["--set", "allow_dev_key=true"]
    return []

BASELINE = ("import time, zenoh, robot_nodes.runtime as r; "
            "s = r.open_session(r.BusConfig(connect=[{endpoint!r}])); time.sleep(3600)")
SETTLE_S = 5.0


def cpu_of(argv: list[str], seconds: float) -> float:
    """% of one core the process used over ``seconds`` after settling."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(argv, cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        time.sleep(SETTLE_S)
        if proc.poll() is not None:
            raise SystemExit(f"{argv} exited with {proc.returncode}")
        p = psutil.Process(proc.pid)
        t0, c0 = time.monotonic(), sum(p.cpu_times()[:2])
        time.sleep(seconds)
        return 100.0 * (sum(p.cpu_times()[:2]) - c0) / (time.monotonic() - t0)
    finally:
        proc.terminate()
        proc.wait(10)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.seconds = 1.0
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = open_router([endpoint])
    params = str(robots.params_file("minibot"))
    try:
        baseline = cpu_of([sys.executable, "-c", BASELINE.format(endpoint=endpoint)], args.seconds)
        print(f"{'baseline (runtime imported, session open)':44s} {baseline:5.2f} %")
        figures = {}
        for name in IDLE_NODES:
            argv = [sys.executable, "-m", NODES[name].module, "--robot-id", "idle1", "--connect", endpoint,
                    "--params", params, *extra_arguments(name)]
            figures[name] = cpu_of(argv, args.seconds)
            print(f"{name:44s} {figures[name]:5.2f} %  ({figures[name] - baseline:+.2f} over the baseline)")
    finally:
        router.close()
    quiet = {n: v for n, v in figures.items() if n != "hcm"}
    print(f"RESULT idle baseline_pct={baseline:.2f} " + " ".join(f"{n}_pct={v:.2f}" for n, v in figures.items())
          + f" max_idle_pct={max(quiet.values()):.2f}")


if __name__ == "__main__":
    main()
