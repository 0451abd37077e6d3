"""freeze_startup_heap in a process of its own (freezing the test runner would keep its garbage for good): what
lived at start-up is out of the collector's sight, garbage made later is still collected."""

from __future__ import annotations

import subprocess
import sys

from tests.support import REPO

PROGRAM = """
import gc, weakref
from wire.heap import freeze_startup_heap

class Node:
    pass

kept = [Node() for _ in range(1000)]  # what a process builds at start-up and keeps
frozen = freeze_startup_heap()
later = Node()
later.self = later  # a cycle made after start-up, then dropped: only the collector can free it
gone = weakref.ref(later)
del later
gc.collect()
print(frozen, gc.get_freeze_count(), gone() is None)
"""


def test_start_up_objects_are_frozen_and_later_garbage_still_collected() -> None:
    done = subprocess.run([sys.executable, "-c", PROGRAM], cwd=REPO, capture_output=True, text=True, timeout=60,
                          check=True)
    frozen, count, collected = done.stdout.split()
    assert int(frozen) == int(count) > 1000, done.stdout  # the 1000 nodes and the modules
    assert collected == "True", done.stdout
