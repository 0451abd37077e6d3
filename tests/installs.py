"""pitchside installed as users install it: its wheel in a fresh virtualenv outside the checkout, with its
dependencies from a lock file (as on a robot; needs PyPI or pip's cache) or, offline, exactly the profile's
dependencies provided from the test environment's own installed files (nothing downloaded)."""

from __future__ import annotations

import fcntl
import importlib.metadata
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

from tests.support import REPO

LOCKS = REPO / "locks"


@contextmanager
def _building() -> Iterator[None]:
    """One build in the checkout at a time: setuptools writes build/ and pitchside.egg-info there, and test files
    on two workers build at once."""
    with (Path(tempfile.gettempdir()) / f"pitchside-build-{os.getuid()}.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def build_dist(into: Path) -> tuple[Path, Path]:
    """The sdist and the wheel built from it, as a release makes them (`python -m build`), without a network: the
    build backend from this environment (--no-isolation)."""
    with _building():
        built = subprocess.run([sys.executable, "-m", "build", "--no-isolation", "--outdir", str(into), str(REPO)],
                               capture_output=True, text=True, timeout=300)
    assert built.returncode == 0, built.stdout[-3000:] + built.stderr[-3000:]
    (sdist,) = into.glob("pitchside-*.tar.gz")
    (wheel,) = into.glob("pitchside-*.whl")
    return sdist, wheel


def build_wheel(into: Path) -> Path:
    """The wheel a release publishes: built from the sdist, offline (so every install test also shows that the
    sdist makes a working wheel)."""
    return build_dist(into)[1]


def build_wheel_from_checkout(into: Path) -> Path:
    """The wheel built straight from the checkout (pip wheel), without a network."""
    with _building():
        # setuptools keeps build/lib between builds and packs what it holds: a file deleted from the checkout since
        # the last build would still ship (a stale build/ is an artefact, never the checkout's content)
        shutil.rmtree(REPO / "build", ignore_errors=True)
        built = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w",
                                str(into), str(REPO)], capture_output=True, text=True, timeout=300)
    assert built.returncode == 0, built.stderr[-3000:]
    (wheel,) = into.glob("pitchside-*.whl")
    return wheel


def fresh_venv(where: Path) -> Path:
    subprocess.run([sys.executable, "-m", "venv", str(where)], check=True, timeout=300)
    return where


def pip(venv: Path, *args: str, timeout: float = 900) -> None:
    # no PYTHONPATH: the checkout must not leak into the installed program
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    done = subprocess.run([str(venv / "bin" / "python"), "-m", "pip", *args], capture_output=True, text=True,
                          timeout=timeout, env=env)
    assert done.returncode == 0, done.stderr[-3000:]


def borrow_test_dependencies(venv: Path) -> None:
    """Dependencies from the test's own environment (a .pth line), never pitchside itself."""
    site = Path(subprocess.run([str(venv / "bin" / "python"), "-c", "import sysconfig; print(sysconfig.get_paths()"
                                "['purelib'])"], capture_output=True, text=True, check=True).stdout.strip())
    (site / "zz_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")


def install_locked(venv: Path, profile: str) -> None:
    """A profile's dependencies exactly as locked, every file checked against its hash (as the README says)."""
    pip(venv, "install", "-q", "--require-hashes", "-r", str(LOCKS / f"{profile}.txt"))


def install_wheel(venv: Path, wheel: Path) -> None:
    pip(venv, "install", "-q", "--no-deps", "--no-index", str(wheel))


def installed_megabytes(venv: Path) -> float:
    """What the virtualenv takes on disk (files, not links to the base Python)."""
    total = sum(p.lstat().st_size for p in venv.rglob("*") if p.is_file() and not p.is_symlink())
    return total / 1e6


def profile_distributions(profile: str) -> list[importlib.metadata.Distribution]:
    """The distributions a profile installs, as installed in the test environment: pitchside's requirements for
    the profile (core: none of its extras), followed through every dependency's own requirements, markers and
    extras evaluated as pip evaluates them here."""
    found: dict[str, importlib.metadata.Distribution] = {}
    todo: list[tuple[str, frozenset[str]]] = [("pitchside", frozenset() if profile == "core" else frozenset({profile}))]
    done: set[tuple[str, frozenset[str]]] = set()
    while todo:
        name, extras = todo.pop()
        if (name, extras) in done:
            continue
        done.add((name, extras))
        dist = importlib.metadata.distribution(name)
        for line in dist.requires or []:
            req = Requirement(line)
            if req.marker is not None and not any(req.marker.evaluate({"extra": e}) for e in (*extras, "")):
                continue
            dep = canonicalize_name(req.name)
            if dep != "pitchside":
                found[dep] = importlib.metadata.distribution(dep)
            todo.append((dep, frozenset(req.extras)))
    return [found[n] for n in sorted(found)]


def provide_profile(venv: Path, profile: str) -> None:
    """A profile's dependencies without a network: the test environment's installed files of exactly those
    distributions, linked one by one into a folder the virtualenv reads as a site directory. The virtualenv then
    sees the profile and nothing more (pip sees them installed: a pip install of pitchside[profile] resolves
    offline)."""
    site = venv / "profile-site"
    for dist in profile_distributions(profile):
        for file in dist.files or []:
            if ".." in file.parts:  # scripts in bin/: not needed, the venv's pitchside script is its own
                continue
            source = Path(str(dist.locate_file(file)))
            if not source.is_file():
                continue
            target = site / file
            target.parent.mkdir(parents=True, exist_ok=True)
            if not target.exists():
                target.symlink_to(source)
    purelib = Path(subprocess.run([str(venv / "bin" / "python"), "-c", "import sysconfig; print(sysconfig.get_paths()"
                                   "['purelib'])"], capture_output=True, text=True, check=True).stdout.strip())
    (purelib / "zz_profile.pth").write_text(f"import site; site.addsitedir({str(site)!r})\n")


def pip_install_extra(venv: Path, wheel: Path, profile: str) -> None:
    """As pipx or a user does it: pip install 'pitchside[profile]' from the wheel, its requirements resolved by
    pip against what is installed (no index: a requirement the profile does not provide fails the install)."""
    target = str(wheel) if profile == "core" else f"{wheel}[{profile}]"
    pip(venv, "install", "-q", "--no-index", "--no-cache-dir", target)


def profile_megabytes(venv: Path) -> float:
    """What a profile's virtualenv takes once its linked dependencies are counted as the files they stand for (the
    links to the base Python, as installed_megabytes, are not)."""
    linked = {p.resolve() for p in (venv / "profile-site").rglob("*") if p.is_symlink() and p.is_file()}
    return installed_megabytes(venv) + sum(p.stat().st_size for p in linked) / 1e6
