"""The dashboard in Debian's chromium: panels show what real nodes publish over Zenoh (screenshots in test-output/)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import httpx
import pytest

import schemas
from robot_nodes.runtime import BusConfig, Node
from tests.dashboard_server import RunningServer, dashboard_server
from tests.support import REPO
from tests.teststand import SceneStand, TestStand
from tests.waiting import wait_for

OUTPUT = REPO / "test-output"
pytestmark = [pytest.mark.slow, pytest.mark.browser]


class Talker(Node):
    """Event-driven and slow streams: a sentence now and then, a strategy every few seconds."""

    __test__ = False
    name = "talker"

    def setup(self) -> None:
        self.speak = self.publisher("speak")
        self.strategy = self.publisher("strategy")
        self.timer(self.tick, rate_hz=0.2)

    def tick(self) -> None:
        self.speak.publish(schemas.make("humanoid_league_msgs/msg/Speak", text="ball"))
        self.strategy.publish(schemas.make("humanoid_league_msgs/msg/Strategy"))


def test_panels_show_live_data(browser: Any, scene: RunningServer, stands: dict[str, SceneStand],
                               bus: BusConfig) -> None:
    OUTPUT.mkdir(exist_ok=True)
    page = browser.new_page(bypass_csp=True, viewport={"width": 1600, "height": 2100})
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(scene.page_url("all"))
    page.evaluate("localStorage.clear(); localStorage.setItem('pitchside.focus', 'r1')")
    page.reload()
    timeout = 30_000

    # team overview: a card per robot with the HCM state, the penalty and the link health
    page.wait_for_selector('.card[data-robot="r1"] .hcm-state:text("WALKING")', timeout=timeout)
    page.wait_for_selector('.card[data-robot="r2"] .penalized:text("PENALIZED")', timeout=timeout)
    assert page.text_content('.card[data-robot="r1"] .game-state') == "PLAYING"
    assert "joint2 42 °C" in page.text_content('.card[data-robot="r1"]')
    assert page.get_attribute('.card[data-robot="r1"]', "data-status") == "ok"

    # link health: a silent event-driven (speak) or slow (strategy) stream is shown grey, never stale or lost
    talker = Talker("r1", bus).start()
    row = '.card[data-robot="r1"] tr[data-topic="{}"]'
    page.wait_for_selector(row.format("robot_state") + '[data-health="ok"]', timeout=timeout)
    for topic in ("speak", "strategy"):
        page.wait_for_function(f"""() => {{ const r = document.querySelector('{row.format(topic)}');
            return r && Number(r.cells[1].textContent) >= 2 * window.pitchside.config.stale_after_s; }}""",
                               timeout=timeout)
        assert page.get_attribute(row.format(topic), "data-health") == "event"
        assert page.get_attribute(row.format(topic), "class") == "event-row"

    # field view: both robots drawn where they are, the ball seen by them, the game state bar
    page.wait_for_function("window.pitchside.fieldView && window.pitchside.fieldView.drawn.length === 2",
                           timeout=timeout)
    drawn = {r["id"]: (r["x"], r["y"]) for r in page.evaluate("window.pitchside.fieldView.drawn")}
    assert drawn == {"r1": (-2.0, 1.0), "r2": (2.0, -1.5)}
    assert page.evaluate("window.pitchside.fieldView.balls") == 2

    # HCM graph: the states the HCM exported, the current one highlighted, the history listed
    page.wait_for_selector('.hcm-node.current[data-state="WALKING"]', timeout=timeout)
    assert page.locator(".hcm-node").count() == 7
    assert page.locator(".history-list li").count() == 3
    page.hover('.hcm-node[data-state="FALLING"]')
    assert page.locator(".hcm-edge.active").count() == 3  # 2 in, 1 out
    assert "WALKING → FALLING: imu tilt" in page.text_content('[data-panel="hcm"] .tip')

    # camera: the JPEG decoded with the ball marker; markers can be switched off
    page.wait_for_function("window.pitchside.camera.images > 0 && "
                           "window.pitchside.camera.markers.ball_in_image === 1", timeout=timeout)
    assert page.evaluate("[window.pitchside.camera.width, window.pitchside.camera.height]") == [320, 240]
    assert page.evaluate("window.pitchside.camera.markers.goal_in_image") == 1

    # diagnostics of every node
    page.wait_for_selector('tr[data-node="r1/scenestand"]', timeout=timeout)
    page.wait_for_selector('tr[data-node="r2/scenestand"]', timeout=timeout)
    page.mouse.move(5, 5)
    page.screenshot(path=str(OUTPUT / "dashboard.png"), full_page=False)

    # click r2 on the field: it becomes the focused robot
    box = page.locator('[data-panel="field"] canvas').bounding_box()
    view = page.evaluate("""() => { const c = document.querySelector('[data-panel="field"] canvas');
        const w = c.clientWidth, h = c.clientHeight;
        const s = Math.min(w / (9 + 1.4), (h - 28) / (6 + 1.4));
        return [w / 2 + 2.0 * s, 28 + (h - 28) / 2 + 1.5 * s]; }""")
    page.mouse.click(box["x"] + view[0], box["y"] + view[1])
    page.wait_for_function("window.pitchside.store.focus === 'r2'", timeout=timeout)
    page.wait_for_selector('.card.focused[data-robot="r2"]', timeout=timeout)
    page.locator('[data-panel="camera"] input[data-topic="ball_in_image"]').uncheck()
    page.wait_for_function("window.pitchside.camera.markers.ball_in_image === 0", timeout=timeout)
    page.screenshot(path=str(OUTPUT / "dashboard-focus-r2.png"), full_page=False)

    # a robot that goes silent is marked stale, then lost after 5 s
    stands["r1"].shutdown()
    talker.shutdown()
    page.wait_for_selector('.card[data-robot="r1"][data-status="stale"]', timeout=timeout)
    page.wait_for_selector('.card[data-robot="r1"][data-status="lost"]', timeout=timeout)
    page.wait_for_selector(row.format("robot_state") + '[data-health="lost"].lost-row', timeout=timeout)
    assert page.get_attribute(row.format("speak"), "data-health") == "event"
    assert page.get_attribute('.card[data-robot="r2"]', "data-status") == "ok"
    page.wait_for_function("window.pitchside.fieldView.drawn.find(r => r.id === 'r1').silent === true",
                           timeout=timeout)
    page.wait_for_selector('tr.level-3[data-node="r1/scenestand"]', timeout=timeout)
    assert page.locator('tr.level-0[data-node="r2/scenestand"]').count() == 1
    page.screenshot(path=str(OUTPUT / "dashboard-r1-lost.png"), full_page=False)
    assert not errors, errors


def test_the_page_names_what_the_msg_files_name(browser: Any, scene: RunningServer) -> None:
    """State names, colours, levels and event topics in the page come from the server, and agree with the schemas."""
    page = browser.new_page(bypass_csp=True)
    page.goto(scene.url)
    page.wait_for_function("window.pitchside && window.pitchside.schemas", timeout=30_000)
    shown = page.evaluate("""async () => {
        const m = await import(new URL("msgtypes.js", location.href).href);
        const values = [...Array(20).keys()];
        return { hcm: values.map(m.hcmName), game: values.map(m.gameName), secondary: values.map(m.secondaryName),
                 obstacle: values.map(m.obstacleColor), level: values.map(m.diagnosticLevelName),
                 unknown: m.hcmName(255),
                 events: [...window.pitchside.store.eventTopics].sort() }; }""")
    hcm = schemas.constant_names("humanoid_league_msgs/msg/RobotControlState")
    game = schemas.constant_names("humanoid_league_msgs/msg/GameState", "GAMESTATE_")
    secondary = schemas.constant_names("humanoid_league_msgs/msg/GameState", "STATE_")
    obstacle = schemas.constant_names("humanoid_league_msgs/msg/ObstacleRelative")
    level = schemas.constant_names("diagnostic_msgs/msg/DiagnosticStatus")
    for i in range(20):
        assert shown["hcm"][i] == hcm.get(i, f"state {i}")
        assert shown["game"][i] == game.get(i, "unknown")
        assert shown["secondary"][i] == secondary.get(i, "")
        assert shown["obstacle"][i] == obstacle.get(i, "")
        assert shown["level"][i] == level.get(i, str(i))
    assert shown["unknown"] == "unknown"  # RobotOverview.UNKNOWN: the robot has not said yet
    assert shown["events"] == sorted(t.name for t in schemas.TOPICS.values() if t.event)


def test_a_hidden_camera_panel_receives_no_images(browser: Any, scene: RunningServer, bus: BusConfig) -> None:
    """Hiding the camera panel withdraws its subscription: the server sends the page no image after that (counted
    by the page's connection); shown again, the images come back."""
    streamer = TestStand("r3", bus, overrides={"image_hz": 10.0, "rate_hz": 5.0}).start()
    try:
        page = browser.new_page(bypass_csp=True, viewport={"width": 1600, "height": 2100})
        page.goto(scene.page_url("all"))
        page.evaluate("localStorage.clear(); localStorage.setItem('pitchside.focus', 'r3')")
        page.reload()
        counts = "window.pitchside?.conn?.counts ?? {images: 0, robots: 0}"  # undefined until the app has run
        wait_for(lambda: page.evaluate(counts)["images"] > 5, 30.0, 0.2, "camera images arriving at 10 Hz")
        page.click('[data-panel="camera"] button[data-act="hide"]')
        rate = "window.pitchside?.conn ? window.pitchside.conn.book.rate('*|camera/image/compressed') ?? 'none' : null"
        assert wait_for(lambda: page.evaluate(rate), 10.0, 0.1, "the page's connection") == "none"
        # the server sends a robots frame every 0.5 s after what it had queued: two of them, and every image
        # queued before the unsubscribe has arrived; from then on, none may come
        robots = page.evaluate(counts)["robots"]
        wait_for(lambda: page.evaluate(counts)["robots"] >= robots + 2, 10.0, 0.1, "the queue drained")
        images = page.evaluate(counts)["images"]
        wait_for(lambda: page.evaluate(counts)["robots"] >= robots + 8, 15.0, 0.1, "3 s more of robots frames")
        assert page.evaluate(counts)["images"] == images, "a hidden camera panel still received images"
        page.evaluate("window.pitchside.layout.show('camera')")
        wait_for(lambda: page.evaluate(counts)["images"] > images + 3, 30.0, 0.2, "images again once shown")
        page.close()
    finally:
        streamer.shutdown()


def test_layout_is_changed_and_remembered(browser: Any, scene: RunningServer) -> None:
    page = browser.new_page(bypass_csp=True, viewport={"width": 1400, "height": 2400})  # no scrolling while dragging
    page.goto(scene.page_url("all"))
    page.evaluate("localStorage.clear()")
    page.reload()
    page.wait_for_selector('[data-panel="team"]')
    order = page.eval_on_selector_all("#grid > .panel", "els => els.map(e => e.dataset.panel)")
    assert order[:2] == ["team", "field"]
    page.click('[data-panel="field"] button[data-act="left"]')
    page.click('[data-panel="plots"] button[data-act="hide"]')
    page.drag_and_drop('[data-panel="diagnostics"] > header h2', '[data-panel="field"]')
    page.select_option("#columns-select", "4")
    page.reload()
    page.wait_for_selector('[data-panel="team"]')
    order = page.eval_on_selector_all("#grid > .panel", "els => els.map(e => e.dataset.panel)")
    assert order[:3] == ["diagnostics", "field", "team"] and "plots" not in order, order
    assert page.eval_on_selector("#grid", "g => getComputedStyle(g).getPropertyValue('--columns').trim()") == "4"
    page.select_option("#add-panel", "plots")
    assert page.locator('[data-panel="plots"]').count() == 1


def _picture(view: Any) -> Any:
    from io import BytesIO

    from PIL import Image

    return Image.open(BytesIO(view.screenshot())).convert("L")


def _changed_pixels(before: Any, after: Any) -> int:
    """Pixels of the embedded 3D view that changed clearly (the robot's meshes appearing over grid and sky)."""
    from PIL import ImageChops

    if before.size != after.size:
        return 0
    diff = ImageChops.difference(before, after).crop((0, 0, after.width, max(1, after.height - 24)))
    return sum(diff.point(lambda v: 255 if v > 30 else 0).histogram()[255:])


def test_robot3d_panel_shows_viser(browser: Any, router_endpoint: str, bus: BusConfig, testdata: Path,
                                   tmp_path: Path) -> None:
    """The 3D panel embeds viser's own client, which draws the Wolfgang URDF driven by joint_states, in sight."""
    from tests.support import free_port
    from tests.teststand import TestStand

    wolfgang = testdata / "robots" / "wolfgang"
    joints = "HeadPan,HeadTilt,LShoulderPitch,RShoulderPitch,LElbow,RElbow,LKnee,RKnee"
    node: TestStand | None = None
    port3d = free_port()
    args = ["--connect", router_endpoint, "--no-telemetry", "--robot3d", "--robot3d-port", str(port3d),
            "--urdf", str(wolfgang / "urdf" / "robot.urdf"), "--package", f"wolfgang_description={wolfgang}"]
    try:
        with dashboard_server(args, tmp_path) as server:
            page = browser.new_page(bypass_csp=True, viewport={"width": 1600, "height": 1100})
            page.goto(server.page_url("all"))
            page.set_default_timeout(60_000)  # a loaded CI machine: the resized panel settles slowly before its picture
            page.evaluate("localStorage.clear()")
            page.reload()
            src = page.get_attribute('[data-panel="robot3d"] iframe', "src")
            assert src == "robot3d/view/"  # through the dashboard's own origin, not viser's port
            frame = page.frame_locator('[data-panel="robot3d"] iframe')
            frame.locator("canvas").first.wait_for(timeout=60_000)
            # chromium throttles an off-screen iframe: viser applies scene updates only when shown
            panel = page.locator('[data-panel="robot3d"]')
            panel.scroll_into_view_if_needed()
            view = page.locator('[data-panel="robot3d"] .robot3d-clip')
            page.wait_for_timeout(2000)  # viser's page settles (grid, notices) before the baseline picture
            empty = _picture(view)  # no robot yet: the URDF is loaded on its first joint_states
            node = TestStand("r1", bus, overrides={"rate_hz": 20.0, "joints": joints}).start()

            def shown() -> Any:
                status = httpx.get(f"{server.url}/api/robot3d", timeout=10).json()
                assert not status["failed"], status["failed"]
                return status["robots"].get("r1", {}).get("updates", 0) > 0

            wait_for(shown, 60.0, 0.2, "the 3D view applied joint_states")
            # the robot is in sight: not under viser's control panel or its software-rendering notice
            wait_for(lambda: _changed_pixels(empty, _picture(view)) > 1500, 60.0, 1.0,
                     "the robot drawn in the embedded 3D view")
            viser = next(f for f in page.frames if f.url.startswith(f"{server.url}/robot3d/view/"))
            viser.evaluate("window.pitchsideMark = 1")
            page.click('[data-panel="robot3d"] button[data-act="wider"]')
            page.click('[data-panel="robot3d"] button[data-act="taller"]')
            assert panel.bounding_box()["width"] > 700
            assert viser.evaluate("window.pitchsideMark") == 1  # resizing a panel does not reload its iframe
            panel.scroll_into_view_if_needed()
            panel.screenshot(path=str(OUTPUT / "robot3d.png"))
    finally:
        if node is not None:
            node.shutdown()
