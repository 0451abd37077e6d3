"""The README's map for newcomers names files that exist: a moved or renamed file fails here, not in a reader's
first hour."""

from __future__ import annotations

import re

from tests.support import REPO

PATH = re.compile(r"`((?:schemas|wire|robot_nodes|server|web|robots|pitchside|tests|bench)/[\w/.<>-]*)`")


def test_every_file_the_readme_names_exists() -> None:
    text = (REPO / "README.md").read_text()
    named = {m.group(1) for m in PATH.finditer(text) if "<" not in m.group(1)}
    assert len(named) > 30, "the map is missing"
    missing = sorted(path for path in named if not (REPO / path.rstrip("/")).exists())
    assert not missing, missing
