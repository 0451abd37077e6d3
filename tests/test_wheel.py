"""pitchside as pipx installs it: an isolated virtualenv outside the checkout with `pip install 'pitchside[all]'`
from the built wheel (tests/conftest.py: profile_venv) runs the demo and prints its link; the robot descriptions
and the web page come from the installed package (importlib.resources), not from the checkout."""

from __future__ import annotations

import subprocess
from collections.abc import Callable
from pathlib import Path

import httpx
import pytest

from tests.running_demo import running_demo
from tests.waiting import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.install]


def test_the_all_install_runs_the_demo_outside_the_checkout(profile_venv: Callable[[str], Path],
                                                             tmp_path: Path) -> None:
    venv = profile_venv("all")
    elsewhere = tmp_path / "somewhere"
    elsewhere.mkdir()
    imported = subprocess.run([str(venv / "bin" / "python"), "-c", "import robots, server, web; "
                               "print(server.__file__); print(robots.urdf()); print(web.ROOT)"],
                              cwd=elsewhere, capture_output=True, text=True)
    assert imported.returncode == 0, imported.stderr[-3000:]
    where = imported.stdout.split()
    assert all(p.startswith(str(venv)) for p in where), where  # the installed package, not the checkout
    with running_demo(tmp_path, program=[str(venv / "bin" / "pitchside")], cwd=elsewhere) as demo:
        assert f"open {demo.login_url}" in demo.output()  # the link it prints signs the browser in
        page = wait_for(lambda: _get(f"{demo.url}/"), 60.0, 0.2, "the page")
        assert page is not None and "pitchside" in page.text and _get(f"{demo.url}/app.js") is not None
        heard = wait_for(lambda: (r := _get(f"{demo.url}/api/robots")) and any(
            x["robot"] == "robot1" and "joint_states" in x["streams"] for x in r.json()), 90.0, 0.5,
            "robot1's joint states from the installed simulation")
        assert heard
        params = httpx.get(f"{demo.url}/api/robots/robot1/params", headers=demo.auth, timeout=30)
        assert params.status_code == 200 and "walking" in params.json(), params.text[:500]
        assert "Traceback" not in demo.output(), demo.output()[-3000:]


def _get(url: str) -> httpx.Response | None:
    try:
        reply = httpx.get(url, timeout=5)
    except httpx.HTTPError:
        return None
    return reply if reply.status_code == 200 else None
