"""How the suite shares two cores: the simulations that must keep real time one after another, the rest around them.

``./run test`` runs two xdist workers with ``--dist loadfile``, scheduled here: each test file goes whole to one
worker (its module fixtures and servers stay together), and the files in ``REALTIME_FILES`` (simulations whose
outcome needs the world to keep real time: kicks, the head, the HCM, walking, behaviour, the match) count as one
file, so two of them never compete for the cores; they start first (together the longest work), then the other
files with slow tests, then the many short ones. Their tests carry the ``realtime`` mark (``-m realtime``).

Tried and dropped: a third worker, the others at nice 10 to let the simulation keep its core. As root,
Chromium raises its own GPU process to nice -8; the starved workers lost their 10 to 20 s waits, and the suite took
no less time (868 s against about 800 s).

(xdist's own ``loadgroup`` cannot do this with pytest 9: its group suffix goes into ``Item._nodeid``, which pytest
9 no longer reads, so every test became a group of its own.)
"""

from __future__ import annotations

from pathlib import PurePosixPath

import pytest
from xdist.scheduler import LoadScopeScheduling

REALTIME_FILES = frozenset({
    "test_behavior_sim.py", "test_head_sim.py", "test_hcm_sim.py", "test_kick_sim.py", "test_match.py",
    "test_walking_sim.py",
})
REALTIME_SCOPE = "real-time simulations"


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
