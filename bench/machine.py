"""How fast this machine runs Python right now, for the benches whose figures are CPU shares.

A CPU share (% of one core) is only comparable between runs on a machine of the same speed. The 2-core machines the
budgets are set on have been seen to run the same work at half their usual speed for hours, with no steal time or
load to show it; this probe makes that visible next to each figure. It times a fixed pure-Python workload (the kind
of work the nodes do: attribute access, small arithmetic, calls), best of three so a passing hiccup does not count.
"""

from __future__ import annotations

import argparse
import time

# the probe's time on the 2-core CI machine at the fastest it has been seen (2026-11-29); minutes later it took
# 177 ms (1.6 x), and earlier sessions saw it at about half speed for hours
REFERENCE_MS = 112.0


def _work(n: int) -> float:
    total = 0.0
    point = [0.0, 0.0]
    for i in range(n):
        point[i & 1] += i * 0.5
        total += point[0] - point[1]
    return total


def probe_ms(n: int = 1_000_000) -> float:
    """Milliseconds for the fixed workload, best of three."""
    best = float("inf")
    for _ in range(3):
        started = time.perf_counter()
        _work(n)
        best = min(best, time.perf_counter() - started)
    return best * 1e3


def describe(ms: float) -> str:
    """The probe's time and its ratio to the reference (> 1: slower than the machine at its fastest)."""
    return f"speed probe {ms:.0f} ms ({ms / REFERENCE_MS:.2f} x this machine at its fastest, {REFERENCE_MS:.0f} ms)"


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="the same probe: it takes well under a second")
    parser.parse_args()
    ms = probe_ms()
    print(describe(ms))
    print(f"RESULT machine probe_ms={ms:.0f} ratio={ms / REFERENCE_MS:.2f}")
