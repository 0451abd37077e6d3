"""Memory over time with the plots open: does a live plot make the browser or the server hoard memory?

    python bench/plots_memory.py [--minutes 4] [--robots 1]

Runs the real demo and two headless chromiums side by side for ``--minutes``: one shows only the plots panel
(rerun's viewer, fed by the server with numbers thinned to 10 Hz per stream and the state lanes), the baseline
shows only the team overview. Every 10 s it reads the unique memory (USS) of each browser's processes and of the
dashboard server, and prints how fast each grows after a one-minute warm-up (least-squares slope, MB/min), with
the plots browser's growth against the baseline's (their difference; the ratio too when the baseline grows at
all). Chromium here draws WebGL in software, and a process's memory moves in steps: take runs of several
minutes. rerun's gRPC server keeps at most 256 MiB of history in the
server process; the viewer in the browser keeps what it was sent, so its slope says how long a day of plots
lasts.
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import httpx
import psutil

from tests.running_demo import running_demo
from tests.support import launch_chromium

SAMPLE_S = 10.0
WARM_UP_S = 60.0


def open_page(pw: Any, url: str, panel: str) -> tuple[Any, Any]:
    """A chromium showing only one panel of the dashboard."""
    browser = launch_chromium(pw)
    page = browser.new_page(bypass_csp=True, viewport={"width": 1600, "height": 900})
    page.set_default_timeout(120_000)
    page.goto(url)
    page.wait_for_function("window.pitchside?.layout")
    page.evaluate("""(keep) => { localStorage.clear(); const layout = window.pitchside.layout;
        layout.state = layout.defaults(); for (const p of layout.state.panels) p.hidden = p.id !== keep;
        layout.save(); }""", panel)
    page.reload()
    page.wait_for_function("window.pitchside?.layout")
    return browser, page


def uss_mb(processes: list[psutil.Process]) -> float:
    total = 0
    for p in processes:
        with contextlib.suppress(psutil.Error):  # a renderer that ended between listing and reading
            total += p.memory_full_info().uss
    return total / 1e6


def tree(root: psutil.Process) -> list[psutil.Process]:
    try:
        return [root, *root.children(recursive=True)]
    except psutil.Error:
        return []


def slope_mb_per_min(samples: list[tuple[float, float]]) -> float:
    """Least-squares growth of (seconds, MB) samples, in MB per minute."""
    if len(samples) < 2:
        return float("nan")
    return statistics.linear_regression([t for t, _ in samples], [m for _, m in samples]).slope * 60.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=4.0)
    parser.add_argument("--robots", type=int, default=1)
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.minutes = 0.05
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory() as tmp, running_demo(Path(tmp), "--robots", str(args.robots)) as demo, \
            sync_playwright() as pw:
        server = next(p for p in demo.processes() if "server" in " ".join(p.cmdline()))
        before = set(psutil.Process().children(recursive=True))
        plots_browser, _ = open_page(pw, demo.url, "plots")
        plots_procs = [p for p in psutil.Process().children(recursive=True) if p not in before]
        before |= set(plots_procs)
        base_browser, _ = open_page(pw, demo.url, "team")
        started = time.monotonic()
        logged0 = httpx.get(f"{demo.url}/api/plots", timeout=10).json()["logged"]
        series: dict[str, list[tuple[float, float]]] = {"plots": [], "baseline": [], "server": []}
        while (now := time.monotonic() - started) < args.minutes * 60.0:
            plots_now = [p for root in plots_procs if root.is_running() for p in tree(root)]
            base_now = [p for p in psutil.Process().children(recursive=True) if p not in before]
            figures = {"plots": uss_mb(plots_now), "baseline": uss_mb(base_now), "server": uss_mb([server])}
            if now >= WARM_UP_S:
                for name, mb in figures.items():
                    series[name].append((now, mb))
            print(f"{now:6.0f} s  " + "  ".join(f"{name} {mb:7.1f} MB" for name, mb in figures.items()),
                  flush=True)
            time.sleep(SAMPLE_S)
        logged_per_s = (httpx.get(f"{demo.url}/api/plots", timeout=10).json()["logged"] - logged0) / \
            (time.monotonic() - started)
        plots_browser.close()
        base_browser.close()

    slopes = {name: slope_mb_per_min(s) for name, s in series.items()}
    # the baseline browser hardly grows, so the plots' own share is the difference; the ratio only means
    # something when the baseline grows too
    extra = slopes["plots"] - slopes["baseline"]
    ratio = slopes["plots"] / slopes["baseline"] if slopes["baseline"] > 0.5 else float("nan")
    last = {name: s[-1][1] if s else float("nan") for name, s in series.items()}
    print(f"after {args.minutes:.0f} min: plots browser {last['plots']:.0f} MB, baseline browser "
          f"{last['baseline']:.0f} MB, server {last['server']:.0f} MB; messages plotted {logged_per_s:.0f}/s")
    print(f"RESULT plots_memory browser_mb_per_min={slopes['plots']:.2f} baseline_mb_per_min="
          f"{slopes['baseline']:.2f} plots_extra_mb_per_min={extra:.2f} ratio={ratio:.2f} "
          f"server_mb_per_min={slopes['server']:.2f} "
          f"plotted_msgs_per_s={logged_per_s:.0f}")


if __name__ == "__main__":
    main()
