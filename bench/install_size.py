"""Installed size of each install profile: its lock file and the wheel in a fresh virtualenv, as the README says.

    python bench/install_size.py [--profiles robot,dashboard,sim,dev]

Needs PyPI (or pip's cache). The baseline is the whole program with the test tools (locks/dev.txt, what
`./run setup` installs); the robot profile's goal is under 250 MB.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.installs import build_wheel, fresh_venv, install_locked, install_wheel, installed_megabytes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--profiles", default="robot,dashboard,sim,dev")
    args = parser.parse_args()
    profiles = [p.strip() for p in args.profiles.split(",") if p.strip()]
    folder = Path(tempfile.mkdtemp(prefix="pitchside-bench-install-"))
    sizes: dict[str, float] = {}
    try:
        wheel = build_wheel(folder / "wheels")
        for profile in profiles:
            started = time.perf_counter()
            venv = fresh_venv(folder / profile)
            install_locked(venv, profile)
            install_wheel(venv, wheel)
            sizes[profile] = installed_megabytes(venv)
            print(f"{profile}: {sizes[profile]:.0f} MB installed in {time.perf_counter() - started:.0f} s")
            shutil.rmtree(venv)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    figures = " ".join(f"{p}_mb={mb:.0f}" for p, mb in sizes.items())
    ratio = f" robot_vs_dev={sizes['robot'] / sizes['dev']:.2f}" if {"robot", "dev"} <= sizes.keys() else ""
    print(f"RESULT install_size {figures}{ratio}")


if __name__ == "__main__":
    main()
