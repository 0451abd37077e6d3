"""Every bench runs: ``python bench/<name>.py --smoke`` for a few seconds ends with its ``RESULT <name>`` line, so a
bench broken by a change fails here instead of on the day someone measures. The figures are not judged (a smoke run is
too short to mean anything); that it runs to the end and says so is.

The heavy ones (a browser, a whole demo or match, wheels installed, network namespaces) are marked slow and run
only when asked (PITCHSIDE_BENCH_SMOKE=all): together they take longer than the suite has room for.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys

import pytest

from tests.support import REPO

BENCHES = sorted(p.stem for p in (REPO / "bench").glob("*.py") if not p.stem.startswith("_"))
HEAVY = {  # bench -> why it is slow or needs more than Python
    "demo": "the whole demo for 3 s",
    "faults": "kills and restarts each process of a stack",
    "idle": "each node alone, settling 5 s",
    "install_size": "builds and installs the wheel",
    "match": "a 1 v 1 match",
    "network": "network namespaces",
    "plots_memory": "a browser",
    "server": "a browser and 11 robots' telemetry",
    "team": "a simulated team with the server",
    "world": "worlds of robot processes",
    "hcm": "the motion chain at several rates",
    "walking": "the motion chain at several rates",
    "foxglove": "the Foxglove endpoint with clients",
    "export_rerun": "a log written and exported",
    "replay": "a log written and replayed",
    "latency": "node processes for each publisher kind",
    "telemetry": "the sender against a budget, several rounds",
    "chaos": "a 1 v 1 match with processes killed",
    "plots_lag": "the demo and a browser",
}
RESULT_NAME = {"network": "net", "install_size": "install_size_offline"}  # a bench whose RESULT line names it otherwise
BROWSER = {"plots_memory", "server", "demo", "plots_lag"}
TIMEOUT_S = 600


# The heavy ones take 25-60 s each (seven minutes together) on 2 cores: beyond what the suite's 15 minutes have room
# for, so they run when asked (PITCHSIDE_BENCH_SMOKE=all ./run test tests/test_bench_smoke.py)
ALL_BENCHES = os.environ.get("PITCHSIDE_BENCH_SMOKE") == "all"


def _marks(name: str) -> list[pytest.MarkDecorator]:
    marks = [pytest.mark.slow] if name in HEAVY else []
    if name in HEAVY and not ALL_BENCHES:
        marks.append(pytest.mark.skip(reason=f"{HEAVY[name]}: PITCHSIDE_BENCH_SMOKE=all runs it"))
    if name in BROWSER:
        marks.append(pytest.mark.browser)
    if name == "network" and (os.geteuid() != 0 or shutil.which("ip") is None):
        marks.append(pytest.mark.skip(reason="network namespaces need root and iproute2"))
    return marks


@pytest.mark.parametrize("name", [pytest.param(n, marks=_marks(n), id=n) for n in BENCHES])
def test_the_bench_runs_in_its_smoke_mode(name: str) -> None:
    out = subprocess.run([sys.executable, f"bench/{name}.py", "--smoke"], cwd=REPO, capture_output=True, text=True,
                         timeout=TIMEOUT_S, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    tail = f"{out.stdout[-2000:]}\n{out.stderr[-2000:]}"
    assert out.returncode == 0, tail
    results = [line for line in out.stdout.splitlines() if line.startswith("RESULT ")]
    assert results and results[-1].split()[1] == RESULT_NAME.get(name, name), tail


def test_every_bench_is_run_here() -> None:
    """A new bench without --smoke fails its own test above; one named here but gone is a stale entry."""
    assert set(HEAVY) <= set(BENCHES) and set(BENCHES) >= BROWSER
    for name in BENCHES:
        assert "--smoke" in (REPO / "bench" / f"{name}.py").read_text(), name
