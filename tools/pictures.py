"""`./run pictures`: the README's and the documentation's pictures, taken when a person asks (never by the suite).

What a user came for, at 1920x1080 in Debian's chromium: the Match preset during a simulated 4 v 4 match (two teams
on the field, every robot's card), the Lab preset on the demo, and the Replay preset replaying a recording the demo
just made. Each is taken only once every panel of its preset draws and the page fits the window without scrolling
(the same checks as tests/test_demo_browser.py), so a picture never shows a half-loaded dashboard.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx

from tests.pictures import layout_problems, silent_panels
from tests.running_demo import RunningDemo, running_demo
from tests.support import REPO, launch_chromium
from tests.waiting import wait_for

OUT = REPO / "docs" / "pictures"
MATCH_ROBOTS = 8  # 4 v 4, the kid-size game
PLAY_S = 15.0  # of play before the match picture
RECORDING_S = 6.0  # the demo recording the Replay picture replays
DRAW_TIMEOUT_S = 180.0  # software WebGL (the 3D view, the plots) on a 2-core machine


def _say(text: str) -> None:
    print(f"[pictures] {text}", flush=True)


@contextlib.contextmanager
def _page(url: str) -> Iterator[Any]:
    """A fresh 1920x1080 page of Debian's chromium at ``url`` (nothing remembered from an earlier layout)."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        browser = launch_chromium(pw)
        try:
            page = browser.new_page(viewport={"width": 1920, "height": 1080})
            page.goto(url)
            page.evaluate("localStorage.clear()")
            yield page
        finally:
            browser.close()


def _shoot(page: Any, preset: str, out: Path) -> Path:
    """The preset's picture once it fits and every panel it shows (web/presets.js says which) draws."""
    panels: list[str] = page.eval_on_selector_all("#grid > .panel", "els => els.map(e => e.dataset.panel)")
    page.mouse.move(1919, 1079)  # no hover marks in the picture
    wait_for(lambda: not silent_panels(page, panels), DRAW_TIMEOUT_S, 2.0,
             lambda: f"every panel of {preset} drawing ({silent_panels(page, panels)} drew nothing)")
    problems = layout_problems(page, panels)
    if problems:
        raise SystemExit(f"[pictures] the {preset} preset does not fit 1920x1080: {problems}")
    path = out / f"{preset}.png"
    page.screenshot(path=str(path))
    _say(f"{path.relative_to(REPO) if path.is_relative_to(REPO) else path}")
    return path


def _open_preset(page: Any, demo: RunningDemo, preset: str) -> None:
    page.goto(f"{demo.page_url(preset)}&robot={'home1' if preset == 'match' else 'robot1'}")
    page.wait_for_selector(f'#presets button[data-preset="{preset}"][aria-pressed="true"]')


def take_match(out: Path, log_dir: Path) -> Path:
    """A simulated 4 v 4 in its first half, watched by the match dashboard."""
    _say("starting a simulated 4 v 4 match (pitchside match --robots 4v4), about a minute to kick-off")
    args = ("--robots", "4v4", "--half-minutes", "2", "--initial-seconds", "2", "--ready-seconds", "20",
            "--set-seconds", "2")
    with running_demo(log_dir, *args, command="match") as match, _page(match.login_url) as page:
        _open_preset(page, match, "match")
        wait_for(lambda: page.locator('section[data-panel="team"] .card').count() >= MATCH_ROBOTS, 120.0, 1.0,
                 "every robot's card in the team overview")
        wait_for(lambda: page.locator('section[data-panel="game"] .panel-body[data-state="PLAYING"]').count() == 1,
                 180.0, 1.0, "the kick-off (PLAYING)")
        time.sleep(PLAY_S)  # the robots spread out from their kick-off places
        return _shoot(page, "match", out)


def take_lab_and_replay(out: Path, log_dir: Path) -> list[Path]:
    """The demo's robot in the Lab preset, then a recording of it replayed in the Replay preset."""
    _say("starting the demo (pitchside demo)")
    taken = []
    with running_demo(log_dir) as demo, _page(demo.login_url) as page:
        http = httpx.Client(base_url=demo.url, headers=demo.auth, timeout=60.0)
        _open_preset(page, demo, "lab")
        taken.append(_shoot(page, "lab", out))
        assert http.post("/api/recordings/start", json={"name": "pictures"}).status_code == 200
        time.sleep(RECORDING_S)  # the recording's length, not a wait for a condition
        stopped = http.post("/api/recordings/stop")
        stopped.raise_for_status()
        name = Path(stopped.json()["path"]).name
        assert http.post("/api/replay/open", json={"path": name}).status_code == 200
        assert http.post("/api/replay/play").status_code == 200
        _open_preset(page, demo, "replay")
        page.wait_for_selector(".playback-bar:not([hidden])")
        http.post("/api/replay/pause")
        assert http.post("/api/replay/seek", json={"t_s": RECORDING_S / 2}).status_code == 200
        taken.append(_shoot(page, "replay", out))
    return taken


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="./run pictures", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--only", choices=["match", "lab-replay"], help="take one group only")
    parser.add_argument("--out", type=Path, default=OUT, help="where the PNGs go (default docs/pictures)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="pitchside-pictures-") as logs:
        os.environ["PITCHSIDE_RECORDINGS"] = str(Path(logs) / "recordings")  # not the user's recordings/
        if args.only in (None, "match"):
            take_match(args.out, Path(logs))
        if args.only in (None, "lab-replay"):
            take_lab_and_replay(args.out, Path(logs))
    _say("done; review them (git diff --stat docs/pictures) before committing")
    return 0


if __name__ == "__main__":
    sys.exit(main())
