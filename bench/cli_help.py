"""How long ``pitchside --help`` and ``pitchside demo --help`` take, and whether they load a web framework.

    python bench/cli_help.py [--runs 7] [--repo PATH] [--smoke]

Each run is a fresh interpreter (what a user's shell starts), timed from start to exit; the figure is the median.
A command's help must not import the dashboard (FastAPI, Starlette, uvicorn), MuJoCo or Zenoh's nodes: the budget is
0.5 s for each on this machine. ``--repo`` times another checkout with this interpreter (a baseline: main's tree).
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BUDGET_S = 0.5
HEAVY = ("fastapi", "starlette", "uvicorn", "mujoco", "viser", "rerun")
# runs the command line as the console script does, then names the heavy modules it loaded
PROBE = ("import sys\nfrom pitchside.cli import main\nsys.argv = ['pitchside', *{args!r}]\n"
         "try:\n    main()\nexcept SystemExit:\n    pass\n"
         "print('LOADED', ' '.join(sorted(m for m in {heavy!r} if m in sys.modules)), file=sys.stderr)\n")


def _children_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def one_run(repo: Path, args: list[str]) -> tuple[float, float, list[str]]:
    """Wall and CPU seconds of one fresh ``pitchside <args>`` and the heavy modules it imported (the CPU time
    hardly changes with what else the machine runs; the wall time is what the user waits)."""
    code = PROBE.format(args=args, heavy=HEAVY)
    started, cpu0 = time.perf_counter(), _children_cpu_s()
    done = subprocess.run([sys.executable, "-c", code], cwd=repo, capture_output=True, text=True, timeout=120)
    elapsed, cpu = time.perf_counter() - started, _children_cpu_s() - cpu0
    if "usage:" not in done.stdout:
        raise SystemExit(f"pitchside {' '.join(args)} printed no help: {done.stdout[-300:]} {done.stderr[-300:]}")
    loaded = next((line.split()[1:] for line in done.stderr.splitlines() if line.startswith("LOADED")), [])
    return elapsed, cpu, loaded


def measure(repo: Path, args: list[str], runs: int) -> tuple[float, float, list[str]]:
    """Median wall and CPU seconds over ``runs`` and every heavy module any run loaded."""
    results = [one_run(repo, args) for _ in range(runs)]
    return (statistics.median(r[0] for r in results), statistics.median(r[1] for r in results),
            sorted({m for r in results for m in r[2]}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--repo", type=Path, default=REPO, help="the checkout to time (default: this one)")
    parser.add_argument("--smoke", action="store_true", help="one run each: that it works, not what it costs")
    args = parser.parse_args()
    runs = 1 if args.smoke else args.runs
    one_run(args.repo, ["--help"])  # the first start reads the files from disk: not what a user waits for twice
    help_s, help_cpu, help_loaded = measure(args.repo, ["--help"], runs)
    demo_s, demo_cpu, demo_loaded = measure(args.repo, ["demo", "--help"], runs)
    for line, wall, cpu, loaded in (("pitchside --help", help_s, help_cpu, help_loaded),
                                    ("pitchside demo --help", demo_s, demo_cpu, demo_loaded)):
        print(f"{line:22} {wall * 1e3:7.0f} ms wall, {cpu * 1e3:6.0f} ms CPU (median of {runs}), "
              f"loads: {', '.join(loaded) or '-'}")
    print(f"budget {BUDGET_S * 1e3:.0f} ms each: {'met' if max(help_s, demo_s) < BUDGET_S else 'MISSED'} "
          f"(wall; a busy machine adds to it, the CPU time does not)")
    print(f"RESULT cli_help help_ms={help_s * 1e3:.0f} demo_help_ms={demo_s * 1e3:.0f} "
          f"help_cpu_ms={help_cpu * 1e3:.0f} demo_help_cpu_ms={demo_cpu * 1e3:.0f} "
          f"heavy_modules={len(set(help_loaded) | set(demo_loaded))}")


if __name__ == "__main__":
    main()
