"""A match day in half an hour: the demo's memory stays flat (opt-in: PITCHSIDE_SOAK_MINUTES=30 ./run test -k soak).

Every process of `pitchside demo` is sampled every 30 s; after the warm-up (the first third of the run, in which
the stated caps fill: the hub's queues, the plots' history, the link-health windows) each process's RSS slope
must stay under 0.2 MB/min per robot. bench/team.py measures the same slope for the server with 8 robots.
"""

from __future__ import annotations

import os
import statistics
import time
from pathlib import Path

import psutil
import pytest

from tests.running_demo import process_label, running_demo

MINUTES = float(os.environ.get("PITCHSIDE_SOAK_MINUTES", "0"))
ROBOTS = int(os.environ.get("PITCHSIDE_SOAK_ROBOTS", "1"))
SLOPE_MB_PER_MIN_PER_ROBOT = 0.2
SAMPLE_S = 30.0
PLOTS_MEMORY = "8MiB"

pytestmark = [pytest.mark.slow, pytest.mark.skipif(MINUTES <= 0, reason="opt-in: PITCHSIDE_SOAK_MINUTES=30"),
              pytest.mark.timeout(MINUTES * 60 + 300)]


def test_every_process_of_the_demo_keeps_its_memory_flat(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # rerun's plot history is capped (256 MiB by default), and one robot's plots take over 50 minutes to fill it.
    # rerun's server grows to about 35 MB + twice its cap (measured: 8 MiB -> 46 MB after 4 minutes, 48 MB from the
    # 14th, flat; 32 MiB -> 97 MB after 30 minutes, still filling), so an 8 MiB cap is full within the warm-up and
    # the slope after it shows whether anything grows past its cap
    monkeypatch.setenv("PITCHSIDE_PLOTS_MEMORY", PLOTS_MEMORY)
    samples: dict[str, list[tuple[float, float]]] = {}
    with running_demo(tmp_path, "--robots", str(ROBOTS)) as demo:
        t0 = time.monotonic()
        while (elapsed := time.monotonic() - t0) < MINUTES * 60:
            for p in demo.processes():
                try:
                    rss_mb = p.memory_info().rss / 1e6
                    samples.setdefault(f"{process_label(p)} [{p.pid}]", []).append((elapsed / 60, rss_mb))
                except psutil.Error:
                    continue
            time.sleep(SAMPLE_S)
    warm = MINUTES / 3
    slopes = {}
    for name, points in samples.items():
        late = [(t, mb) for t, mb in points if t >= warm]
        if len(late) >= 3:
            xs, ys = zip(*late, strict=True)
            slopes[name] = statistics.linear_regression(xs, ys).slope
    for name, slope in sorted(slopes.items(), key=lambda x: -x[1]):
        print(f"{slope:+.3f} MB/min  {name}  ({samples[name][0][1]:.0f} -> {samples[name][-1][1]:.0f} MB)")
    assert slopes, "no process was sampled after the warm-up"
    limit = SLOPE_MB_PER_MIN_PER_ROBOT * ROBOTS
    growing = {n: round(s, 3) for n, s in slopes.items() if s > limit}
    assert not growing, f"RSS grows faster than {limit} MB/min after the warm-up: {growing}"
