"""A team on one laptop: what each further simulated robot costs, and whether 8 of them keep real time.

    python bench/team.py [--seconds 60] [--robots 1,2,4,8] [--soak-minutes 0]

For each N it runs the demo's stack as `pitchside demo --robots N --match` starts it: the MuJoCo world (robot1
renders its head camera, the others perceive without images), each robot's nodes composed (four robots to a
process, the demo's default), the simulated GameController, and the dashboard server in match mode, which gets
everything through one-way telemetry. After start-up it measures for ``--seconds``: the CPU time of every process
of the stack (% of one core), their summed RSS, the process count, and the world's real-time factor (the cm730
sim node's ``real_time_factor`` diagnostic: sim seconds per wall second over each 1 s, read on the demo's Zenoh
bus); its minimum is the figure. The server's RSS is sampled every second; its slope after a warm-up is the memory
growth (``--soak-minutes`` runs the largest N that long, for the 30-minute soak of a match day).

The baseline, in the same run: one robot with each node in a process of its own (``--compose none``), the layout
the thesis measured against its monolith (fig. 6.5), beside one robot composed.

Before each run, bench/machine.py times a fixed Python workload: CPU shares are comparable only between runs on a
machine of the same speed, and this one has run at half its speed for hours with nothing else to show it.

Budgets (issue "A team on one laptop", 2-core machine): rtf_min_8 >= 0.98, cpu_pct_per_robot <= 15,
rss_mb_per_robot <= 150.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import statistics
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import psutil

from bench.machine import describe, probe_ms
from tests.real_time_factor import ROUTER, RealTimeFactor
from tests.running_demo import RunningDemo, process_label, running_demo

WARM_UP_S = 15.0  # after the dashboard answers: every robot stood up, the match recording started


@dataclass
class Figures:
    """One run of the stack."""

    label: str
    robots: int
    seconds: float = 0.0
    cpu_pct: float = 0.0
    rss_mb: float = 0.0
    processes: int = 0
    rtf: list[float] = field(default_factory=list)
    by_process: list[tuple[str, float, float]] = field(default_factory=list)  # (name, cpu %, rss MB)
    server_rss: list[tuple[float, float]] = field(default_factory=list)  # (minutes, MB)
    probe_ms: float = 0.0  # bench/machine.py just before the run: the machine's speed then

    @property
    def rtf_min(self) -> float:
        return min(self.rtf) if self.rtf else 0.0

    @property
    def server_slope(self) -> float:
        """MB per minute, least squares over the samples after the warm-up (the window's first third, in which the
        stated caps fill: the hub's queues, the plots' history, the link-health windows; as tests/test_soak.py)."""
        end = self.server_rss[-1][0] if self.server_rss else 0.0
        late = [(t, mb) for t, mb in self.server_rss if t >= end / 3]
        if len(late) < 3:
            return 0.0
        xs, ys = zip(*late, strict=True)
        return float(statistics.linear_regression(xs, ys).slope)


@contextlib.contextmanager
def stack(robots: int, compose: str, lab: bool = False) -> Iterator[RunningDemo]:
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["PITCHSIDE_RECORDINGS"] = str(Path(tmp) / "recordings")
        with running_demo(Path(tmp), "--robots", str(robots), *([] if lab else ["--match"]), "--cameras", "1",
                          "--compose", compose) as demo:
            yield demo


def measure(robots: int, compose: str, seconds: float, lab: bool = False) -> Figures:
    mode = "lab (live Zenoh)" if lab else "match (telemetry)"
    figures = Figures(f"{robots} robot{'s' if robots > 1 else ''}, compose {compose}, {mode}", robots,
                      probe_ms=probe_ms())
    with stack(robots, compose, lab) as demo:
        found = ROUTER.search(demo.output())
        if found is None:
            raise SystemExit("the demo did not say where its Zenoh router is")
        rtf = RealTimeFactor(found.group(1))
        try:
            time.sleep(WARM_UP_S)
            procs = demo.processes()
            server = next(p for p in procs if process_label(p) == "server")
            before = {p.pid: sum(p.cpu_times()[:2]) for p in procs}
            t0 = time.monotonic()
            stop = threading.Event()

            def sample_server() -> None:
                while not stop.wait(1.0):
                    with contextlib.suppress(psutil.Error):
                        figures.server_rss.append(((time.monotonic() - t0) / 60.0, server.memory_info().rss / 1e6))

            sampler = threading.Thread(target=sample_server, daemon=True)
            sampler.start()
            time.sleep(seconds)
            stop.set()
            sampler.join(5)
            t1 = time.monotonic()
            gone = [process_label(p) for p in procs if not p.is_running()]
            if gone:
                raise SystemExit(f"{figures.label}: processes died during the measurement: {gone}")
            procs = demo.processes()  # with any started meanwhile (e.g. a layout by graphviz): all their CPU counts
            for p in procs:
                with contextlib.suppress(psutil.Error):
                    cpu = 100.0 * (sum(p.cpu_times()[:2]) - before.get(p.pid, 0.0)) / (t1 - t0)
                    figures.by_process.append((process_label(p), cpu, p.memory_info().rss / 1e6))
            figures.seconds = t1 - t0
            figures.cpu_pct = sum(c for _, c, _ in figures.by_process)
            figures.rss_mb = sum(r for _, _, r in figures.by_process)
            figures.processes = len(procs)
            figures.rtf = rtf.between(t0, t1)
        finally:
            rtf.close()
    if not figures.rtf:
        raise SystemExit(f"{figures.label}: no real_time_factor report arrived")
    return figures


def show(f: Figures) -> None:
    print(f"\n{f.label}: CPU {f.cpu_pct:.0f} % of one core, RSS {f.rss_mb:.0f} MB, {f.processes} processes, "
          f"real-time factor min {f.rtf_min:.3f} (median {statistics.median(f.rtf):.3f}, {len(f.rtf)} windows of "
          f"1 s), server RSS slope {f.server_slope:+.2f} MB/min over {f.seconds:.0f} s; {describe(f.probe_ms)}")
    for name, cpu, rss in sorted(f.by_process, key=lambda x: -x[1]):
        print(f"  {cpu:6.1f} %  {rss:6.0f} MB  {name}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="measured seconds per run, after start-up")
    parser.add_argument("--robots", default="1,2,4,8", help="the team sizes to run, comma-separated")
    parser.add_argument("--no-lab", action="store_true", help="skip the lab runs (the server on live Zenoh)")
    parser.add_argument("--soak-minutes", type=float, default=0.0,
                        help="run the largest team this long instead (the server's memory slope over a match day)")
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.seconds, args.robots, args.no_lab = 3.0, "1", True
    sizes = sorted({int(n) for n in args.robots.split(",")})
    load = os.getloadavg()[0]
    split = measure(1, "none", args.seconds)
    show(split)
    runs: dict[int, Figures] = {}
    for n in sizes:
        seconds = args.soak_minutes * 60.0 if args.soak_minutes and n == sizes[-1] else args.seconds
        runs[n] = measure(n, "all", seconds)
        show(runs[n])
    server_lab_per_robot = float("nan")
    if not args.no_lab:  # the dashboard in the lab: every topic of every robot live over Zenoh
        lab = [measure(n, "all", args.seconds, lab=True) for n in (sizes[0], min(4, sizes[-1]))]
        for figures in lab:
            show(figures)
        server_cpu = [next(c for name, c, _ in f.by_process if name == "server") for f in lab]
        server_lab_per_robot = (server_cpu[1] - server_cpu[0]) / max(lab[1].robots - lab[0].robots, 1)
    first, last = runs[sizes[0]], runs[sizes[-1]]
    match_server = [next(c for name, c, _ in f.by_process if name == "server") for f in (first, last)]
    server_match_per_robot = (match_server[1] - match_server[0]) / max(last.robots - first.robots, 1)
    extra = max(last.robots - first.robots, 1)
    cpu_per_robot = (last.cpu_pct - first.cpu_pct) / extra
    rss_per_robot = (last.rss_mb - first.rss_mb) / extra
    composed_1 = runs[1].cpu_pct if 1 in runs else float("nan")
    print(f"\nper further robot ({first.robots} -> {last.robots}): {cpu_per_robot:.1f} % of one core, "
          f"{rss_per_robot:.0f} MB; one robot composed {composed_1:.0f} % against split {split.cpu_pct:.0f} % "
          f"(ratio {composed_1 / split.cpu_pct:.2f}); the server per further robot: {server_match_per_robot:.1f} % "
          f"in a match, {server_lab_per_robot:.1f} % in the lab; machine: {psutil.cpu_count()} cores, load average "
          f"{load:.1f} at the start")
    print(f"RESULT team cpu_pct_per_robot={cpu_per_robot:.1f} rss_mb_per_robot={rss_per_robot:.0f} "
          f"rtf_min_{last.robots}={last.rtf_min:.3f} cpu_pct_{last.robots}={last.cpu_pct:.0f} "
          f"split_cpu_pct_1={split.cpu_pct:.0f} composed_cpu_pct_1={composed_1:.0f} "
          f"server_rss_slope_mb_per_min={last.server_slope:.2f} server_match_cpu_pct_per_robot="
          f"{server_match_per_robot:.1f} server_lab_cpu_pct_per_robot={server_lab_per_robot:.1f} "
          f"probe_ms_1={first.probe_ms:.0f} probe_ms_{last.robots}={last.probe_ms:.0f}")


if __name__ == "__main__":
    main()
