"""Script injection, in Debian's chromium with the page's own Content-Security-Policy in force: names and strings
from the bus (any process on it) and from a log file (another team's) carry markup, and the dashboard shows them
as text and runs none of it."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

import pytest
import zenoh
from mcap.writer import Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

import schemas
from schemas import codec
from schemas.logs import LogWriter
from schemas.topics import TOPICS
from tests.dashboard_server import RunningServer, dashboard_server
from tests.waiting import wait_for
from wire.keys import topic_key

pytestmark = [pytest.mark.slow, pytest.mark.browser]
MARKUP = "<img src=x onerror=window.__pwned=1>"
# breaks out of a quoted attribute as well as text; every element it would make is marked, so one query finds them
HOSTILE = "\"'><img src=x data-pwned=1 onerror=window.__pwned=1><b data-pwned=2>pwned</b>"
# counts every marked element ever added to the page, also one a later redraw removed again
WATCH = """() => { window.__injected = []; new MutationObserver((changes) => { for (const c of changes) {
    for (const n of c.addedNodes) { if (!n.querySelectorAll) continue;
      for (const e of [n, ...n.querySelectorAll('[data-pwned]')]) if (e.hasAttribute('data-pwned'))
        window.__injected.push(((e.closest('[data-panel]') || {}).dataset || {}).panel + ': ' +
                               (e.closest('tr') || e.parentElement || e).outerHTML.slice(0, 300)); } } })
  .observe(document, { subtree: true, childList: true }); }"""
SHOW_ALL = "() => { const l = window.pitchside.layout; for (const p of l.state.panels) if (p.hidden) l.show(p.id); }"


def _hostile_log(path: Path) -> None:
    """Another team's log: a robot id, a topic and a bookmark with markup, next to a well-named stream."""
    with LogWriter(path) as writer:
        for k in range(20):
            t = 1_700_000_000_000_000_000 + k * 50_000_000
            state = schemas.make("humanoid_league_msgs/msg/RobotControlState", state=2)
            writer.write(MARKUP, "robot_state", state, log_time_ns=t)
            writer.write("r8", f"odd_{MARKUP}", state, log_time_ns=t)
            writer.write("r8", "robot_state", state, log_time_ns=t)
        writer.add_bookmark(MARKUP, log_time_ns=1_700_000_000_000_000_000 + 500_000_000)


def _publish_hostile(client: zenoh.Session, stop: threading.Event) -> None:
    """A process on the bus: a robot id with markup, and a well-named robot whose strings carry markup."""
    state = schemas.encode(schemas.make("humanoid_league_msgs/msg/RobotControlState", state=2))
    status = schemas.make("diagnostic_msgs/msg/DiagnosticStatus", level=2, name=MARKUP, message=MARKUP,
                          hardware_id=MARKUP, values=[schemas.make("diagnostic_msgs/msg/KeyValue", key=MARKUP,
                                                                   value=MARKUP)])
    diagnostics = schemas.encode(schemas.make("diagnostic_msgs/msg/DiagnosticArray", status=[status]))
    servo = schemas.encode(schemas.make(
        "humanoid_league_msgs/msg/AdditionalServoData",
        temperature=[schemas.make("sensor_msgs/msg/Temperature", temperature=71.0,
                                  header=schemas.make("std_msgs/msg/Header", frame_id=MARKUP))], voltage=[12.0]))
    # an attacker on the bus is not held to ROS 2's namespace rule (topic_key refuses this id): the key by hand
    hostile_key = topic_key("r9", "robot_state").replace("/r9/", f"/{MARKUP}/", 1)
    while not stop.wait(0.1):
        client.put(hostile_key, state)
        client.put(topic_key("r9", "robot_state"), state)
        client.put(topic_key("r9", "diagnostics"), diagnostics)
        client.put(topic_key("r9", "servo_data"), servo)


def test_markup_from_the_bus_and_from_a_log_is_shown_as_text_and_never_runs(
        browser: Any, router_endpoint: str, client: zenoh.Session, tmp_path: Path) -> None:
    rec = tmp_path / "rec"
    rec.mkdir()
    _hostile_log(rec / "other_team.mcap")
    stop = threading.Event()
    publisher = threading.Thread(target=_publish_hostile, args=(client, stop), daemon=True)
    publisher.start()
    try:
        with dashboard_server(["--connect", router_endpoint, "--no-telemetry", "--recordings", str(rec)],
                              tmp_path) as server:
            page = browser.new_page(viewport={"width": 1600, "height": 2400})  # the page's CSP stays in force
            console: list[str] = []
            page.on("console", lambda m: console.append(m.text))
            page.on("pageerror", lambda exc: console.append(str(exc)))
            page.goto(server.page_url("all"))
            reply = server.http.post(f"{server.url}/api/replay/open", json={"path": "other_team.mcap"})
            assert reply.status_code == 200, reply.text
            wait_for(lambda: page.evaluate("document.querySelector('[data-panel=\"diagnostics\"]')?.textContent"
                                           ".includes('<img src=x')"), 30.0, 0.2, "the diagnostics row of r9")
            wait_for(lambda: MARKUP in (page.text_content('.card[data-robot="r9"]') or ""), 30.0, 0.2,
                     "robot r9's card with its hottest servo")
            assert page.evaluate("window.__pwned") is None
            assert page.evaluate("document.querySelectorAll('img[src=\"x\"]').length") == 0
            robots = page.evaluate("window.pitchside.store.robotIds()")
            assert "r9" in robots and not any("<" in r for r in robots), robots  # dropped where it entered
            options = page.evaluate("[...document.querySelectorAll('option')].map((o) => o.value)")
            assert not any("<" in o for o in options), options
            page.reload()
            wait_for(lambda: MARKUP in (page.text_content('[data-panel="replay"]') or ""), 30.0, 0.2,
                     "the log's names in the replay panel")
            assert page.evaluate("window.__pwned") is None
            assert page.evaluate("document.querySelectorAll('img[src=\"x\"]').length") == 0
            violations = [m for m in console if "Content Security Policy" in m]
            assert not violations, violations  # nothing of ours needed the policy to stop it
    finally:
        stop.set()
        publisher.join(5)


def test_a_page_opened_without_the_token_is_view_only_until_signed_in(browser: Any, tmp_path: Path) -> None:
    with dashboard_server(["--no-live", "--no-telemetry"], tmp_path) as server:
        page = browser.new_page(viewport={"width": 1600, "height": 2400})
        errors: list[str] = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        page.goto(server.url + "/")
        page.wait_for_selector('[data-role="access"]', timeout=30_000)
        assert page.text_content('[data-role="access"]') == "view only"
        assert "telemetry: DEV KEY" in (page.text_content('[data-role="telemetry-key"]') or "")
        assert "view only" in (page.text_content('[data-panel="parameters"]') or "")
        assert page.context.cookies() == []
        page.fill(".sign-in input", "wrong")
        page.click(".sign-in button")
        wait_for(lambda: "token" in (page.text_content(".sign-in .lab-status") or ""), 10.0, 0.1, "the refusal")
        page.fill(".sign-in input", server.token)
        page.click(".sign-in button")
        wait_for(lambda: page.locator('[data-role="access"]').count() and
                 page.text_content('[data-role="access"]') == "control", 30.0, 0.2, "signed in after reload")
        cookie = page.context.cookies()[0]
        assert cookie["httpOnly"] and cookie["sameSite"] == "Strict" and cookie["value"] != server.token
        assert page.evaluate("document.cookie") == ""  # no script of the page can read it
        assert not errors, errors


# -- every string of every topic, the parameters, the file names ---------------------------------------------------
def _with_markup(typename: str, depth: int = 0, **numbers: Any) -> Any:
    """A message of the type with HOSTILE in every string (in sequences of strings and of messages too)."""
    fields: dict[str, Any] = dict(numbers)
    definition: Any = codec.typestore().fielddefs[codec.full_name(typename)][1]
    for name, (kind, detail) in definition:
        if name in numbers:  # given by the caller
            continue
        if kind == 1 and detail[0] in ("string", "wstring"):
            fields[name] = HOSTILE
        elif kind == 2 and depth < 4:
            fields[name] = _with_markup(detail, depth + 1)
        elif kind in (3, 4) and detail[0][0] == 1 and detail[0][1][0] in ("string", "wstring"):
            fields[name] = [HOSTILE] * (detail[1] if kind == 3 else 3)
        elif kind == 4 and detail[0][0] == 2 and depth < 4:
            fields[name] = [_with_markup(detail[0][1], depth + 1) for _ in range(2)]
    return schemas.make(typename, **fields)


def _hostile_parameters(client: zenoh.Session, robot: str) -> Any:
    """A ROS 2 node on the bus (its parameter services as rclcpp offers them) whose parameters carry markup in
    their names, values and descriptions; a token that names a node with markup is not a ROS 2 name: not listed."""
    from tests.test_ros2_parameters import STRING, Ros2ParameterNode

    node = Ros2ParameterNode(client, f"/{robot}", "evil_node", doc=HOSTILE,
                             values={"mode": (STRING, HOSTILE), HOSTILE: (STRING, "b")})
    stranger = client.liveliness().declare_token(f"@ros2_lv/0/{client.zid()}/9/9/NN/%/%{robot}/{HOSTILE[:20]}")

    class Both:
        def undeclare(self) -> None:
            node.close()
            stranger.undeclare()
    return Both()


def _publish_every_topic(client: zenoh.Session, robot: str, stop: threading.Event) -> None:
    # an error: the node log shows it whatever its level filter; /rosout is every robot's, the logger name says
    # whose (<robot>.<node>), the node's part hostile
    numbers = {"rosout": {"level": 40, "name": f"{robot}.{HOSTILE}"}}
    payloads = {t.name: schemas.encode(_with_markup(t.type, **numbers.get(t.name, {}))) for t in TOPICS.values()
                if t.type != "sensor_msgs/msg/CompressedImage"}
    assert len(payloads) >= 30, sorted(payloads)
    while not stop.wait(0.2):
        for name, data in payloads.items():
            client.put(topic_key(robot, name), data)


def _injected(page: Any) -> list[str]:
    return [*page.evaluate("window.__injected"), *(["script ran"] if page.evaluate("window.__pwned") else [])]


def test_every_string_of_every_topic_every_parameter_and_file_name_stays_text(
        browser: Any, router_endpoint: str, client: zenoh.Session, tmp_path: Path) -> None:
    """Any process on the bus, with markup in every string of every topic of the table and in its parameters'
    names, values, choices and descriptions, and a recording named with markup: every panel shows them, as text."""
    rec = tmp_path / "rec"
    rec.mkdir()
    with LogWriter(rec / "a'b&c.mcap") as writer:  # a file name a shell allows: quote and ampersand
        writer.write("r8", "robot_state", schemas.make("humanoid_league_msgs/msg/RobotControlState", state=2),
                     log_time_ns=1_700_000_000_000_000_000)
    (rec / f"x{HOSTILE.replace('/', '')}.mcap").write_bytes((rec / "a'b&c.mcap").read_bytes())
    stop = threading.Event()
    publisher = threading.Thread(target=_publish_every_topic, args=(client, "r9", stop), daemon=True)
    publisher.start()
    queryable = _hostile_parameters(client, "r9")
    try:
        with dashboard_server(["--connect", router_endpoint, "--no-telemetry", "--recordings", str(rec)],
                              tmp_path) as server:
            def listing() -> dict[str, Any]:
                reply = server.http.get(f"{server.url}/api/robots/r9/params", timeout=20)
                assert reply.status_code == 200, reply.text
                return dict(reply.json())

            nodes = wait_for(listing, 20.0, 0.2, "r9's parameters listed")
            assert set(nodes) == {"evil_node"}, nodes  # nodes named by the rule, each on its own key
            page = browser.new_page(viewport={"width": 1800, "height": 3200})
            console: list[str] = []
            page.on("console", lambda m: console.append(m.text))
            page.add_init_script(f"({WATCH})()")
            page.goto(server.login_url)
            page.wait_for_function("() => window.pitchside && window.pitchside.layout")
            page.evaluate(SHOW_ALL)
            page.evaluate("window.pitchside.store.setFocus('r9')")
            panels = ["diagnostics", "node_log", "hcm", "team", "parameters", "recordings"]

            def shown() -> list[str]:  # the panels that show the markup (as text) so far
                return [p for p in panels if "data-pwned=2" in (page.text_content(f'[data-panel="{p}"]') or "")]

            wait_for(lambda: len(shown()) == len(panels), 60.0, 0.5, f"markup as text in {panels} (so far {shown()})")
            wait_for(lambda: "data-pwned" in (page.text_content('[data-panel="recordings"]') or ""), 30.0, 0.2,
                     "the file named with markup in the recordings list")
            for node in page.query_selector_all('[data-panel="hcm"] .hcm-node')[:3]:
                node.dispatch_event("mouseenter")  # the tooltip of a state: its transitions' names
            assert "data-pwned=2" in (page.text_content('[data-panel="hcm"] .tip') or "")
            assert _injected(page) == []
            page.reload()  # the page built from the newest messages at once, not only from the updates
            page.wait_for_function("() => window.pitchside && window.pitchside.layout")
            wait_for(lambda: len(shown()) >= 3, 60.0, 0.5, "the markup after a reload")
            assert _injected(page) == []
            assert not [m for m in console if "Content Security Policy" in m]
    finally:
        stop.set()
        publisher.join(5)
        queryable.undeclare()


# -- a log whose schemas give a table topic other types -----------------------------------------------------------
def _definition(*parts: str) -> str:
    """A ros2msg schema text: the type's fields, then each type it uses under its MSG: line."""
    return ("=" * 80 + "\n").join(parts)


_TIME = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
RETYPED = {  # each a table topic's type, a number of it now a string (the file carries its own definitions)
    "rosout": ("rcl_interfaces/msg/Log", _definition("builtin_interfaces/Time stamp\nstring level\nstring name\n"
                                                     "string msg\nstring file\nstring function\nstring line\n",
                                                     _TIME)),
    "diagnostics": ("diagnostic_msgs/msg/DiagnosticArray", _definition(
        "std_msgs/Header header\nDiagnosticStatus[] status\n",
        "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n", _TIME,
        "MSG: diagnostic_msgs/DiagnosticStatus\nstring level\nstring name\nstring message\nstring hardware_id\n"
        "KeyValue[] values\n",
        "MSG: diagnostic_msgs/KeyValue\nstring key\nstring value\n")),
    "robot_state": ("humanoid_league_msgs/msg/RobotControlState", "string state\n"),
    "hcm_graph": ("std_msgs/msg/String", "string data\n"),  # another type altogether
}


def _retyped_log(path: Path) -> None:
    """Another team's log, written with its own schemas (as any MCAP writer may), robot r7."""
    store = get_typestore(Stores.EMPTY)
    for typename, text in RETYPED.values():
        store.register(get_types_from_msg(text, typename))
    types = store.types
    with path.open("wb") as f:
        writer = Writer(f)
        writer.start(profile="ros2", library="another team")
        channels = {}
        for topic, (typename, text) in RETYPED.items():
            schema = writer.register_schema(typename, "ros2msg", text.encode())
            channels[topic] = writer.register_channel(f"/r7/{topic}", "cdr", schema, {"robot_id": "r7", "topic": topic})
        for k in range(60):
            t = 1_700_000_000_000_000_000 + k * 50_000_000
            stamp = types["builtin_interfaces/msg/Time"](sec=t // 10**9, nanosec=t % 10**9)
            header = types["std_msgs/msg/Header"](stamp=stamp, frame_id="")
            status = types["diagnostic_msgs/msg/DiagnosticStatus"](level=HOSTILE, name="r7/cm730", message=HOSTILE,
                                                                   hardware_id="", values=[])
            messages = {
                "rosout": types["rcl_interfaces/msg/Log"](stamp=stamp, level=HOSTILE, name="cm730", msg=HOSTILE,
                                                          file=HOSTILE, function="f", line=HOSTILE),
                "diagnostics": types["diagnostic_msgs/msg/DiagnosticArray"](header=header, status=[status]),
                "robot_state": types["humanoid_league_msgs/msg/RobotControlState"](state=HOSTILE),
                "hcm_graph": types["std_msgs/msg/String"](data=HOSTILE),
            }
            for topic, (typename, _) in RETYPED.items():
                writer.add_message(channels[topic], log_time=t, publish_time=t,
                                   data=bytes(store.serialize_cdr(messages[topic], typename)))
        writer.finish()


def _replay(server: RunningServer, what: str, body: dict[str, Any] | None = None) -> Any:
    reply = server.http.post(f"{server.url}/api/replay/{what}", json=body or {})
    assert reply.status_code == 200, reply.text
    return reply.json()


def test_a_log_that_retypes_a_table_topic_is_not_replayed_as_that_topic(browser: Any, tmp_path: Path) -> None:
    """A log's own schema for rosout, diagnostics or robot_state with a string where the topic table has a number
    (or another type on hcm_graph) would put that string where panels write numbers (a CSS class): such channels
    are listed with the reason and reach no panel."""
    rec = tmp_path / "rec"
    rec.mkdir()
    _retyped_log(rec / "retyped.mcap")
    with dashboard_server(["--no-live", "--no-telemetry", "--recordings", str(rec)], tmp_path) as server:
        page = browser.new_page(viewport={"width": 1800, "height": 3200})
        page.add_init_script(f"({WATCH})()")
        page.goto(server.login_url)
        page.wait_for_function("() => window.pitchside && window.pitchside.layout")
        page.evaluate(SHOW_ALL)
        info = _replay(server, "open", {"path": "retyped.mcap"})
        _replay(server, "play", None)
        wait_for(lambda: server.http.get(f"{server.url}/api/replay").json()["state"] in ("ended", "paused"), 30.0,
                 0.2, "the replay played to its end")
        wait_for(lambda: all(t in (page.text_content('[data-panel="replay"]') or "") for t in RETYPED), 30.0, 0.2,
                 "the replay panel listing the log's topics")
        assert _injected(page) == []
        problems = {t["topic"]: t["problem"] for t in info["topics"]}
        assert set(problems) == set(RETYPED) and all(problems.values()), problems
        assert not any(t["decodable"] for t in info["topics"]), info["topics"]
        assert "std_msgs/msg/String" in problems["hcm_graph"] and "other fields" in problems["rosout"]
        robots = server.http.get(f"{server.url}/api/robots").json()
        assert not [r for r in robots if r["robot"] == "replay.r7"], robots  # none of its messages reached the hub
