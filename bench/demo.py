"""`pitchside demo` with a browser showing every panel: does the simulation keep real time, and where the CPU goes.

    python bench/demo.py [--seconds 30] [--robots 1] [--no-browser]

Runs the real demo, opens the dashboard in headless chromium with every panel of the default layout (3D view
and plots included), and for ``--seconds`` reads the world's ``real_time_factor`` diagnostic (sim seconds per
wall second, from the cm730 sim node) over the dashboard's own WebSocket, and the CPU of every process
(psutil, % of one core). The machine's 1-minute load average is printed: other work on it shows there.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import psutil

from tests.running_demo import DashboardObserver, cpu_by_process, running_demo
from tests.support import launch_chromium


def open_dashboard(pw: Any, url: str) -> Any:
    browser = launch_chromium(pw)
    page = browser.new_page(bypass_csp=True, viewport={"width": 1600, "height": 2000})
    page.set_default_timeout(120_000)
    page.goto(url)
    page.wait_for_function("window.pitchside?.layout")
    page.evaluate("localStorage.clear()")  # the default layout: every panel
    page.reload()
    page.wait_for_selector(".card")
    return browser


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--robots", type=int, default=1)
    parser.add_argument("--no-browser", action="store_true")
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.seconds, args.no_browser = 3.0, True
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory() as tmp, running_demo(Path(tmp), "--robots", str(args.robots)) as demo, \
            sync_playwright() as pw, DashboardObserver(demo.ws_url, ("diagnostics",)) as observer:
        browser = None if args.no_browser else open_dashboard(pw, demo.url)
        time.sleep(5.0)  # iframes loaded, the world settled
        t0 = time.time()
        stack = demo.processes()
        others = [p for p in psutil.Process().children(recursive=True) if p.pid not in {q.pid for q in stack}]
        cpu = cpu_by_process(stack + others, args.seconds)
        load = os.getloadavg()[0]
        factors = [f for t, f in observer.real_time_factors if t > t0 + 1.0]
        if browser is not None:
            browser.close()
    for name, pct in cpu:
        if pct >= 0.5:
            print(f"{pct:6.1f} %  {name}")
    total = sum(pct for _, pct in cpu)
    if not factors:
        raise SystemExit("no real_time_factor diagnostic arrived")
    median, low = statistics.median(factors), min(factors)
    print(f"{len(factors)} real-time-factor reports over {args.seconds:.0f} s: median {median:.3f}, min {low:.3f}; "
          f"demo{'' if args.no_browser else ' + browser'} CPU {total:.0f} % of one core (machine: 2 cores, "
          f"load average {load:.1f})")
    print(f"RESULT demo real_time_factor_median={median:.3f} real_time_factor_min={low:.3f} cpu_pct={total:.0f} "
          f"load_avg={load:.1f}")


if __name__ == "__main__":
    main()
