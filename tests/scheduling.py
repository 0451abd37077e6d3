"""How the suite shares two cores: real-time simulations one after another, at the priority a robot's control loop
would have; everything else around them, on the other workers, yielding to them.

``./run test`` runs three xdist workers with ``--dist loadfile``, scheduled here: each test file goes whole to one
worker (its module fixtures and servers stay together), and the files in ``REALTIME_FILES`` (simulations whose
outcome needs the world to keep real time: kicks, the head, the HCM, walking, behaviour, the match) count as one
file, so at most one of them runs at any time, and they start first (they are the longest work). A worker lowers
its own priority (nice 10, which needs no privilege) before any other test, so browsers, servers and fuzzers give
way to the simulation; a real-time test puts its worker back to nice 0 where it may (root, as in CI; elsewhere it
keeps the niceness it has). Their tests carry the ``realtime`` mark (``-m realtime`` selects them).

(xdist's own ``loadgroup`` cannot do this with pytest 9: its group suffix goes into ``Item._nodeid``, which pytest
9 no longer reads, so every test became a group of its own.)
"""

from __future__ import annotations

import os
from pathlib import PurePosixPath

import pytest
from xdist.scheduler import LoadScopeScheduling

REALTIME_FILES = frozenset({
    "test_behavior_sim.py", "test_head_sim.py", "test_hcm_sim.py", "test_kick_sim.py", "test_match.py",
    "test_walking_sim.py",
})
REALTIME_SCOPE = "real-time simulations"
YIELDING_NICE = 10


def is_realtime(nodeid: str) -> bool:
    return PurePosixPath(nodeid.split("::", 1)[0]).name in REALTIME_FILES


class RealtimeFirstScheduling(LoadScopeScheduling):
    """``loadfile``, with the real-time files as one file."""

    def _split_scope(self, nodeid: str) -> str:
        return REALTIME_SCOPE if is_realtime(nodeid) else nodeid.split("::", 1)[0]


def pytest_xdist_make_scheduler(config: pytest.Config, log: object) -> LoadScopeScheduling | None:
    if config.getvalue("dist") != "loadfile":
        return None  # another mode asked for by hand: xdist's own
    config.option.loadscopereorder = False  # keep the order below (xdist would sort the files by test count)
    return RealtimeFirstScheduling(config, log)  # type: ignore[arg-type]


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The real-time files first, then files with slow tests, then the rest; each file's tests in the order they
    were written."""
    slow_files = {item.path for item in items if item.get_closest_marker("slow")}
    items.sort(key=lambda item: (not is_realtime(item.nodeid), item.path not in slow_files))
    for item in items:
        if is_realtime(item.nodeid):
            item.add_marker(pytest.mark.realtime)


def _renice_process(nice: int) -> None:
    """Every thread of this process (Linux keeps the niceness per thread; new threads and child processes take
    their creator's)."""
    for tid in os.listdir("/proc/self/task"):
        try:
            os.setpriority(os.PRIO_PROCESS, int(tid), nice)
        except (PermissionError, ProcessLookupError):
            continue  # lowering niceness needs root; a thread may have ended meanwhile


@pytest.hookimpl(tryfirst=True)  # before the test's fixtures start servers, browsers or simulations
def pytest_runtest_setup(item: pytest.Item) -> None:
    if "PYTEST_XDIST_WORKER" not in os.environ or not os.path.isdir("/proc/self/task"):
        return  # one process alone (-n 0, a single test): nothing to give way to
    _renice_process(0 if is_realtime(item.nodeid) else YIELDING_NICE)
