"""Installed size of each install profile: the wheel in a fresh virtualenv with the profile's dependencies, as the
install guide (docs/guides/install.md) says.

    python bench/install_size.py [--profiles core,robot,dashboard,sim,all,dev] [--offline]

By default each profile's lock file is installed (needs PyPI or pip's cache; the core has no lock: its wheel
resolves the core's ranges from the index). --offline measures without a network, as tests/test_installs.py
installs: the test environment's own files of exactly the profile's distributions (the same versions as the locks
where the locks agree) and pip install 'pitchside[profile]' from the wheel; dev is not measured then. The
baseline is the whole program with the test tools (locks/dev.txt, what `./run setup` installs); the robot
profile's goal is under 250 MB.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.installs import (
    build_wheel,
    fresh_venv,
    install_locked,
    install_wheel,
    installed_megabytes,
    pip,
    pip_install_extra,
    profile_megabytes,
    provide_profile,
)


def install(venv: Path, wheel: Path, profile: str, offline: bool) -> float:
    """Installs the profile; returns the megabytes the virtualenv takes."""
    if offline:
        provide_profile(venv, profile)
        pip_install_extra(venv, wheel, profile)
        return profile_megabytes(venv)
    if profile == "core":
        pip(venv, "install", "-q", str(wheel))
    else:
        install_locked(venv, profile)
        install_wheel(venv, wheel)
    return installed_megabytes(venv)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--profiles", default="core,robot,dashboard,sim,all,dev")
    parser.add_argument("--offline", action="store_true", help="the test environment's files, no network")
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.profiles, args.offline = "core", True
    profiles = [p.strip() for p in args.profiles.split(",") if p.strip() and not (args.offline and p.strip() == "dev")]
    folder = Path(tempfile.mkdtemp(prefix="pitchside-bench-install-"))
    sizes: dict[str, float] = {}
    try:
        wheel = build_wheel(folder / "wheels")
        for profile in profiles:
            started = time.perf_counter()
            venv = fresh_venv(folder / profile)
            sizes[profile] = install(venv, wheel, profile, args.offline)
            print(f"{profile}: {sizes[profile]:.0f} MB installed in {time.perf_counter() - started:.0f} s")
            shutil.rmtree(venv)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    figures = " ".join(f"{p}_mb={mb:.0f}" for p, mb in sizes.items())
    ratio = f" robot_vs_dev={sizes['robot'] / sizes['dev']:.2f}" if {"robot", "dev"} <= sizes.keys() else ""
    print(f"RESULT install_size{'_offline' if args.offline else ''} {figures}{ratio}")


if __name__ == "__main__":
    main()
