"""pitchside as a user installs it: the built wheel in a fresh virtualenv outside the checkout runs the demo, whose
robot descriptions and web page come from the installed package (importlib.resources), not from the checkout."""

from __future__ import annotations

import subprocess
from pathlib import Path

import httpx
import pytest

from tests.installs import borrow_test_dependencies, build_wheel, fresh_venv, install_wheel
from tests.running_demo import running_demo
from tests.waiting import wait_for

pytestmark = pytest.mark.slow


def _fresh_venv(tmp_path: Path) -> Path:
    """A virtualenv with only the wheel of pitchside; its dependencies come from the test's own environment
    (a .pth line, so nothing is downloaded), never pitchside itself."""
    venv = fresh_venv(tmp_path / "venv")
    borrow_test_dependencies(venv)
    install_wheel(venv, build_wheel(tmp_path / "wheels"))
    return venv


def test_the_wheel_runs_the_demo_outside_the_checkout(tmp_path: Path) -> None:
    venv = _fresh_venv(tmp_path)
    elsewhere = tmp_path / "somewhere"
    elsewhere.mkdir()
    imported = subprocess.run([str(venv / "bin" / "python"), "-c", "import robots, server, web; "
                               "print(server.__file__); print(robots.urdf()); print(web.ROOT)"],
                              cwd=elsewhere, capture_output=True, text=True)
    assert imported.returncode == 0, imported.stderr[-3000:]
    where = imported.stdout.split()
    assert all(p.startswith(str(venv)) for p in where), where  # the installed package, not the checkout
    with running_demo(tmp_path, program=[str(venv / "bin" / "pitchside")], cwd=elsewhere) as demo:
        page = wait_for(lambda: _get(f"{demo.url}/"), 60.0, 0.2, "the page")
        assert "pitchside" in page.text and _get(f"{demo.url}/app.js") is not None
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
