"""The node log panel in Debian's chromium: a real node's warnings and errors (rosout) appear as the node wrote them,
and the level, robot and text filters narrow them down. Script in a record stays text."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from robot_nodes.runtime import BusConfig, Node
from tests.dashboard_server import RunningServer, dashboard_server
from tests.waiting import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.browser]


class Walker(Node):
    __test__ = False
    name = "walking"


@pytest.fixture
def server(router_endpoint: str, tmp_path: Path) -> Iterator[RunningServer]:
    with dashboard_server(["--connect", router_endpoint, "--no-telemetry"], tmp_path) as running:
        yield running


def test_the_node_log_shows_filters_and_searches(browser: Any, server: RunningServer, bus: BusConfig,
                                                 caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="pitchside")
    r1, r2 = Walker("r1", bus).start(), Walker("r2", bus).start()
    page = browser.new_page(bypass_csp=True, viewport={"width": 1600, "height": 2400})
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    try:
        page.goto(server.page_url("all"))
        page.evaluate("localStorage.clear()")
        page.reload()
        panel = 'section[data-panel="node_log"]'
        page.wait_for_selector(panel, timeout=30_000)

        def rows() -> list[str]:
            return list(page.eval_on_selector_all(f"{panel} tbody tr", "rows => rows.map(r => r.innerText)"))

        def logged_and_shown() -> bool:  # the first records may leave before the server's routes are known
            r1.log.warning("step too long: %d ms", 40)
            r1.log.info("walking started")
            r2.log.error("<img src=x onerror=alert(1)> servo 7 silent")
            shown = " ".join(rows())
            return "step too long: 40 ms" in shown and "servo 7 silent" in shown and "walking started" in shown

        wait_for(logged_and_shown, timeout=30, interval=0.5, what="the records in the panel")
        assert page.locator(f"{panel} tbody img").count() == 0  # the record's markup is text, not an element
        assert any("WARN" in row and "r1" in row and "walking" in row for row in rows())

        page.select_option(f'{panel} [data-role="level"]', label="ERROR and above")
        wait_for(lambda: rows() and all("ERROR" in row for row in rows()), timeout=10, what="errors only")
        page.select_option(f'{panel} [data-role="level"]', label="INFO and above")
        page.select_option(f'{panel} [data-role="robot"]', "r1")
        wait_for(lambda: rows() and all(row.split("\t")[1] == "r1" for row in rows()), timeout=10, what="r1 only")
        page.fill(f'{panel} [data-role="search"]', "too long")
        wait_for(lambda: rows() and all("step too long" in row for row in rows()), timeout=10, what="the search")
        assert not errors, errors
    finally:
        page.close()
        r1.shutdown()
        r2.shutdown()
