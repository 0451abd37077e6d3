"""pitchside installed as users install it: its wheel in a fresh virtualenv outside the checkout, with its
dependencies from a lock file (as on a robot) or borrowed from the test environment (nothing downloaded)."""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
from pathlib import Path

from tests.support import REPO

LOCKS = REPO / "locks"


def build_wheel(into: Path) -> Path:
    """The checkout's wheel, built without a network (setuptools from the test environment)."""
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
