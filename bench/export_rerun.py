"""`pitchside export-rerun` on a 1 GB log: its peak memory (RSS), which must stay flat however long the log.

    python bench/export_rerun.py [--gigabytes 1.0] [--robots 4]

The log is bench/replay.py's (JointState and Imu at 100 Hz, 30 KB CompressedImage at 30 Hz, per robot), made in a
temporary folder and deleted at the end. The command runs as a process of its own; its peak RSS comes from the
kernel (wait4's ru_maxrss). Baseline in the same run: the peak RSS of a process that only imports what the export
imports and opens the log, so the ratio is what exporting adds on top.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from replay import generate

REPO = Path(__file__).resolve().parents[1]
OPEN_ONLY = ("import sys, rerun, tqdm; from schemas.logs import LogSeriesReader; from schemas.numeric import "
             "numeric_fields; r = LogSeriesReader(sys.argv[1]); print(r.message_count); r.close()")


def peak_rss_mb(argv: list[str]) -> tuple[float, float, str]:
    """(peak RSS in MB, seconds, stdout) of a command run to its end."""
    started = time.perf_counter()
    process = subprocess.Popen(argv, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    assert process.stdout is not None
    out = process.stdout.read().decode()
    _, status, usage = os.wait4(process.pid, 0)
    process.returncode = os.waitstatus_to_exitcode(status)
    assert process.returncode == 0, f"{argv} exited with {process.returncode}"
    return usage.ru_maxrss / 1024, time.perf_counter() - started, out  # ru_maxrss: KiB on Linux


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gigabytes", type=float, default=1.0)
    parser.add_argument("--robots", type=int, default=4)
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.gigabytes, args.robots = 0.005, 1
    folder = Path(tempfile.mkdtemp(prefix="pitchside-bench-export-"))
    try:
        log = folder / "big.mcap"
        started = time.perf_counter()
        messages, seconds = generate(log, int(args.gigabytes * 1e9), args.robots)
        size_gb = log.stat().st_size / 1e9
        print(f"wrote {size_gb:.2f} GB, {messages} messages, {seconds:.0f} s of log in "
              f"{time.perf_counter() - started:.0f} s")
        base_mb, _, _ = peak_rss_mb([sys.executable, "-c", OPEN_ONLY, str(log)])
        print(f"baseline (imports + the log opened): peak RSS {base_mb:.0f} MB")
        peak_mb, export_s, out = peak_rss_mb([sys.executable, "-m", "pitchside.cli", "export-rerun", str(log), "-o",
                                              str(folder / "big.rrd"), "--quiet"])
        rrd_mb = (folder / "big.rrd").stat().st_size / 1e6
        print(out.strip())
        print(f"export-rerun: peak RSS {peak_mb:.0f} MB in {export_s:.0f} s ({messages / export_s:.0f} messages/s), "
              f".rrd {rrd_mb:.0f} MB")
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    print(f"RESULT export_rerun log_gb={size_gb:.2f} peak_rss_mb={peak_mb:.0f} baseline_rss_mb={base_mb:.0f} "
          f"rss_vs_baseline={peak_mb / base_mb:.2f} export_s={export_s:.0f} rrd_mb={rrd_mb:.0f}")


if __name__ == "__main__":
    main()
