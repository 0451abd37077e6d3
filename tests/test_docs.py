"""The documentation site builds strictly (a broken link, a missing page or a page left out of the nav fails),
loads nothing from the internet, its generated reference is what the code makes now, its Python snippets run, and
the README stays a README."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support import REPO
from tools import docs_reference

README_MAX_LINES = 200


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The site as `./run docs` builds it (strict: every warning is an error)."""
    out = tmp_path_factory.mktemp("site")
    result = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
                            cwd=REPO, capture_output=True, text=True, timeout=120,
                            env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert result.returncode == 0, f"mkdocs build --strict failed:\n{result.stderr[-3000:]}"
    return out


def test_the_site_builds_strictly_with_every_page(site: Path) -> None:
    for page in ("index.html", "getting-started/demo.html", "guides/install.html", "guides/ros2.html",
                 "concepts/architecture.html", "reference/commands.html", "reference/parameters.html",
                 "reference/http-api.html", "performance/journal.html", "pictures/match.png"):
        assert (site / page).is_file(), page


def test_the_site_loads_nothing_from_the_internet(site: Path) -> None:
    html = "\n".join(p.read_text() for p in site.rglob("*.html"))
    assert "fonts.googleapis.com" not in html and "fonts.gstatic.com" not in html
    for tag in ('<script src="http', '<link rel="stylesheet" href="http', '<img src="http', '<img alt="" src="http'):
        assert tag not in html, tag


def test_the_generated_reference_is_current() -> None:
    stale = docs_reference.stale(docs_reference.generate())
    names = ", ".join(str(p.relative_to(REPO)) for p in stale)
    assert not stale, f"stale reference pages: {names}; run `{docs_reference.COMMAND}` and commit them"


def test_a_stale_page_is_found_and_the_terminal_width_does_not_matter(monkeypatch: pytest.MonkeyPatch,
                                                                      tmp_path: Path) -> None:
    monkeypatch.setenv("COLUMNS", "37")  # argparse wraps --help at the terminal's width
    pages = docs_reference.generate()
    assert not docs_reference.stale(pages)
    page = tmp_path / "commands.md"
    page.write_text(pages[docs_reference.REFERENCE / "commands.md"].replace("--robots", "--robot"))
    assert docs_reference.stale({page: pages[docs_reference.REFERENCE / "commands.md"]}) == [page]


def test_the_readme_fits_on_two_screens() -> None:
    lines = (REPO / "README.md").read_text().splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines; move the rest into docs/"


PYTHON_BLOCK = re.compile(r"^```python\n(.*?)^```", re.M | re.S)


def test_the_python_the_pages_show_runs() -> None:
    """Every Python snippet of the hand-written pages runs as shown (a node example defines its node; nothing
    starts a process: the snippets run under a module name other than __main__). A snippet whose fence has a
    title needs what the title names and runs in the test that gives it (ROS 2's, with a Zenoh session)."""
    ran = 0
    for page in sorted((REPO / "docs").rglob("*.md")):
        for snippet in PYTHON_BLOCK.findall(page.read_text()):
            code = compile(snippet, str(page.relative_to(REPO)), "exec", dont_inherit=True)  # as a reader runs it
            exec(code, {"__name__": "docs_snippet"})
            ran += 1
    assert ran >= 2, "the snippets of Writing a node and Messages and topics are missing"
