"""What a release publishes: `python -m build` makes an sdist and, from it, a wheel, offline (setuptools of this
environment, no build isolation); both pass `twine check --strict`; the metadata carries the licence, classifiers,
project URLs and Python versions; the long description renders as PyPI renders it, with every link and picture
absolute (nothing lies beside it on PyPI); the version is the one of pitchside/__init__.py, which `pitchside
--version` prints; and the wheel built from the sdist holds every file of the wheel built from the checkout. The
install tests (tests/test_installs.py and others) install the wheel built from the sdist."""

from __future__ import annotations

import email.parser
import email.policy
import re
import subprocess
import sys
import tarfile
import tomllib
import zipfile
from email.message import EmailMessage
from html.parser import HTMLParser
from pathlib import Path
from typing import cast

import pytest
import readme_renderer.clean
import readme_renderer.markdown

import pitchside
from tests.installs import build_dist, build_wheel_from_checkout
from tests.support import REPO

PYTHONS = ("3.11", "3.12", "3.13")


@pytest.fixture(scope="module")
def dist(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The sdist and the wheel built from it, as a release makes them (no network: --no-isolation)."""
    out = tmp_path_factory.mktemp("dist")
    build_dist(out)
    return out


def _wheel(dist: Path) -> Path:
    (wheel,) = dist.glob("pitchside-*.whl")
    return wheel


def _sdist(dist: Path) -> Path:
    (sdist,) = dist.glob("pitchside-*.tar.gz")
    return sdist


def metadata(wheel: Path) -> EmailMessage:
    with zipfile.ZipFile(wheel) as zf:
        (name,) = [n for n in zf.namelist() if n.endswith(".dist-info/METADATA")]
        text = zf.read(name).decode()
    return cast(EmailMessage, email.parser.Parser(policy=email.policy.default).parsestr(text))


def test_twine_check_strict_passes_both(dist: Path) -> None:
    checked = subprocess.run([sys.executable, "-m", "twine", "check", "--strict", str(_wheel(dist)),
                              str(_sdist(dist))], capture_output=True, text=True, timeout=120)
    assert checked.returncode == 0, checked.stdout + checked.stderr
    assert checked.stdout.count("PASSED") == 2, checked.stdout


def test_metadata_carries_licence_classifiers_urls_and_pythons(dist: Path) -> None:
    meta = metadata(_wheel(dist))
    assert meta["Name"] == "pitchside"
    assert meta["License-Expression"] == "MIT"
    assert meta.get_all("License-File") == ["LICENSE"]
    with zipfile.ZipFile(_wheel(dist)) as zf:
        licence = [n for n in zf.namelist() if n.endswith(".dist-info/licenses/LICENSE")]
        assert licence and zf.read(licence[0]) == (REPO / "LICENSE").read_bytes()
    classifiers = meta.get_all("Classifier") or []
    assert {f"Programming Language :: Python :: {v}" for v in PYTHONS} <= set(classifiers)
    assert not [c for c in classifiers if c.startswith("License ::")], "the licence is the SPDX expression alone"
    assert meta["Requires-Python"] == f">={PYTHONS[0]}"
    urls = dict(u.split(", ", 1) for u in meta.get_all("Project-URL") or [])
    assert {"Homepage", "Documentation", "Repository", "Issues"} <= urls.keys()
    assert all(u.startswith("https://") for u in urls.values()), urls
    assert meta["Description-Content-Type"] == "text/markdown"
    extras = set(meta.get_all("Provides-Extra") or [])
    assert {"robot", "dashboard", "sim", "all"} <= extras


def test_the_version_comes_from_one_place(dist: Path) -> None:
    assert re.fullmatch(r"\d+\.\d+\.\d+", pitchside.__version__)
    assert metadata(_wheel(dist))["Version"] == pitchside.__version__
    assert _wheel(dist).name.startswith(f"pitchside-{pitchside.__version__}-")
    assert _sdist(dist).name == f"pitchside-{pitchside.__version__}.tar.gz"
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    assert "version" not in project and "version" in project["dynamic"], "a second place for the version"
    printed = subprocess.run([sys.executable, "-m", "pitchside.cli", "--version"], capture_output=True, text=True,
                             timeout=60, cwd=REPO, check=True).stdout
    assert printed == f"pitchside {pitchside.__version__}\n"


class _Targets(HTMLParser):
    """Every link's and picture's target in rendered HTML."""

    def __init__(self) -> None:
        super().__init__()
        self.links: list[str] = []
        self.pictures: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        found = dict(attrs)
        if tag == "a" and found.get("href"):
            self.links.append(str(found["href"]))
        if tag == "img" and found.get("src"):
            self.pictures.append(str(found["src"]))


def render_as_pypi(markdown: str) -> str:
    """PyPI's rendering: readme_renderer's GFM (cmarkgfm) and its cleaner. Without cmarkgfm installed
    (readme-renderer[md]), Python-Markdown renders and the same cleaner keeps what PyPI would keep."""
    html = readme_renderer.markdown.render(markdown)
    if html is None:
        import markdown as python_markdown

        html = readme_renderer.clean.clean(python_markdown.markdown(markdown, extensions=["tables",
                                                                                        "fenced_code"]))
    assert html is not None, "the long description does not render"
    return html


def test_the_long_description_renders_with_absolute_links(dist: Path) -> None:
    """Relative links and pictures of the README lead nowhere on PyPI: setup.py makes them absolute."""
    text = metadata(_wheel(dist)).get_payload()
    assert isinstance(text, str) and text.strip()
    readme = (REPO / "README.md").read_text()
    assert readme.splitlines()[0] in text  # the README, not something else
    targets = _Targets()
    targets.feed(render_as_pypi(text))
    relative = [t for t in targets.links + targets.pictures if not re.match(r"(https?://|mailto:|#)", t)]
    assert not relative, f"relative targets on PyPI: {relative[:10]}"
    repository = dict(u.split(", ", 1) for u in metadata(_wheel(dist)).get_all("Project-URL") or [])["Repository"]
    readme_pictures = re.findall(r"!\[[^\]]*\]\(\s*<?([^)\s>]+)", readme)
    rendered = [p for p in targets.pictures if p.startswith(repository)]
    assert len(rendered) == len([p for p in readme_pictures if not p.startswith("http")]), targets.pictures
    assert all(f"/raw/v{pitchside.__version__}/" in p for p in rendered), rendered


def test_the_sdist_builds_the_same_wheel_as_the_checkout(dist: Path, tmp_path: Path) -> None:
    """Nothing the program needs is left out of the sdist: the wheel made from it (offline) holds the same files as
    the wheel made from the checkout; the sdist carries the locks for the lock-file install and no tests."""
    from_checkout = build_wheel_from_checkout(tmp_path / "checkout")
    with zipfile.ZipFile(_wheel(dist)) as a, zipfile.ZipFile(from_checkout) as b:
        names_a, names_b = set(a.namelist()), set(b.namelist())
    assert names_a == names_b, f"only from the sdist: {sorted(names_a - names_b)[:10]}, only from the checkout: " \
                               f"{sorted(names_b - names_a)[:10]}"
    assert any(n.startswith("web/") and n.endswith(".js") for n in names_a)
    assert any(n.startswith("robots/") and n.endswith(".urdf") for n in names_a)
    with tarfile.open(_sdist(dist)) as tf:
        members = {m.name.split("/", 1)[1] for m in tf.getmembers() if "/" in m.name}
    assert {"pyproject.toml", "setup.py", "README.md", "LICENSE", "locks/robot.txt", "locks/dashboard.txt"} <= members
    assert not [m for m in members if m.startswith("tests/")]
