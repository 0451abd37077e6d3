"""A team's secured bus (`pitchside team-keys`): only the team's processes steer its robots.

A real team router with the team's router.json5 (mutual TLS + access control), real robot routers with the
robots' files (the robot's nodes join theirs in plain TCP on loopback, as `pitchside robot` starts them), real
laptop and viewer sessions with their own files; all on this machine's loopback (tests/test_bus_security_machines
puts them on separate machines). Refused messages are shown missing after an allowed message sent later has
arrived, and where it matters the allowed one follows the refused one on the same session, so it cannot
overtake it.
"""

from __future__ import annotations

import argparse
import json
import stat
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import zenoh
import zenoh.ext

import schemas
from pitchside.team_access import Role
from pitchside.team_certificates import TeamAuthority
from pitchside.team_keys import (
    CA_CERTIFICATE,
    CA_KEY,
    TEAM_FILE,
    Team,
    TeamKeysError,
    add_members,
    create_team,
    member_of,
    read_credentials,
)
from robot_nodes.runtime import BusConfig, Node, ParameterClient, ParameterError, open_router, open_session
from tests.support import REPO, free_port
from tests.waiting import wait_for
from wire import keys
from wire.bus import LEASE_MS, load_config_file, router_config
from wire.machine_router import MachineRouter, start_machine_router

MOTOR_GOALS = keys.topic_key("robot1", "motor_goals")
CMD_VEL = keys.topic_key("robot1", "cmd_vel")


@pytest.fixture
def team(tmp_path: Path) -> Path:
    folder = tmp_path / "team"
    create_team(folder, "Test Team", ["robot1", "robot2"], ["laptop"], ["viewer"], router_port=free_port())
    return folder


@pytest.fixture
def router(team: Path) -> Iterator[zenoh.Session]:
    session = open_router(config_file=team / "router.json5")
    yield session
    session.close()


def member_session(team: Path, member: str, mode: str = "peer", access_control: bool = True) -> zenoh.Session:
    """A laptop's or viewer's session with its own file; without its access control, as a member who edited
    their file."""
    conf = load_config_file(team / f"{member}.json5")
    conf.insert_json5("mode", json.dumps(mode))
    # a robot's file listens where its machine's router does (7447): in a test the member only joins, so it
    # listens on a free port of the same kind and never takes the port from a demo running beside it
    listen = json.loads(conf.get_json("listen/endpoints"))
    conf.insert_json5("listen/endpoints", json.dumps([e.rsplit(":", 1)[0] + ":0" for e in listen]))
    if not access_control:
        conf.insert_json5("access_control/enabled", "false")
    session = zenoh.open(conf)
    wait_for(lambda: session.info.routers_zid(), timeout=10, what=f"{member} connected to the router")
    return session


def edited_file(team: Path, member: str, **changes: Any) -> Path:
    """A copy of a member's file with top-level sections changed, as a member who edited their file."""
    config = json.loads((team / f"{member}.json5").read_text().split("\n", 2)[2])
    for section, value in changes.items():
        if isinstance(value, dict):
            config[section].update(value)
        else:
            config[section] = value
    path = team.parent / f"{member}-edited.json5"
    path.write_text(json.dumps(config))
    return path


def robot_router(team: Path, robot: str, access_control: bool = True) -> MachineRouter:
    """The robot's own router from its file, as `pitchside robot` runs it (here on a free loopback port)."""
    config = team / f"{robot}.json5"
    if not access_control:
        config = edited_file(team, robot, access_control={"enabled": False})
    return start_machine_router([f"tcp/127.0.0.1:{free_port()}"], None, config)


def robot_process(router: MachineRouter) -> zenoh.Session:
    """One of the robot's nodes: a plain peer of the robot's router on loopback, as `pitchside robot` starts it."""
    session = open_session(BusConfig(connect=[router.local_endpoint]))
    wait_for(lambda: session.info.routers_zid(), timeout=10, what="a robot process joined its robot's router")
    return session


def linked_to_team_router(router: MachineRouter, team_router: zenoh.Session) -> bool:
    return str(router.session.info.zid()) in {str(z) for z in team_router.info.routers_zid()}


def goals(sender: str) -> bytes:
    """A real motor_goals message whose joint name says who sent it."""
    point = schemas.make("trajectory_msgs/msg/JointTrajectoryPoint", positions=[0.5])
    return schemas.encode(schemas.make("trajectory_msgs/msg/JointTrajectory", joint_names=[sender], points=[point]))


DRIVERS = ["viewer", "laptop", "outsider"]  # a cmd_vel says who sent it by its speed: 0.1 * (index + 1)


def drive(sender: str) -> bytes:
    vector = "geometry_msgs/msg/Vector3"
    return schemas.encode(schemas.make("geometry_msgs/msg/Twist",
                                       linear=schemas.make(vector, x=0.1 * (DRIVERS.index(sender) + 1), y=0.0, z=0.0),
                                       angular=schemas.make(vector, x=0.0, y=0.0, z=0.0)))


def sender_of(topic: str, raw: bytes) -> str:
    if topic == "cmd_vel":
        return DRIVERS[round(schemas.decode(raw, "geometry_msgs/msg/Twist").linear.x * 10) - 1]
    return str(schemas.decode(raw, "trajectory_msgs/msg/JointTrajectory").joint_names[0])


class ControlInbox:
    """What robot1's processes receive on its control topics: (topic, sender) in arrival order."""

    def __init__(self, session: zenoh.Session) -> None:
        self.got: list[tuple[str, str]] = []
        self._lock = threading.Lock()
        self._subs = [session.declare_subscriber(keys.topic_key("robot1", topic), self._on(topic))
                      for topic in ("motor_goals", "cmd_vel", "record_motor_goals")]
        self._subs.append(session.declare_subscriber(keys.topic_key("robot2", "motor_goals"), self._on("robot2")))

    def _on(self, topic: str) -> Any:
        def on_sample(sample: zenoh.Sample) -> None:
            sender = sender_of(topic, sample.payload.to_bytes())
            with self._lock:
                self.got.append((topic, sender))
        return on_sample

    def senders(self, topic: str) -> list[str]:
        with self._lock:
            return [sender for t, sender in self.got if t == topic]


def wait_matched(publisher: zenoh.Publisher, what: str) -> None:
    """Until the publisher's session knows a subscriber: a put before that would reach nobody, refused or not."""
    # zenoh's stub says bool, the object is a MatchingStatus with .matching (as in robot_nodes.runtime.node)
    wait_for(lambda: publisher.matching_status.matching, timeout=10, what=what)  # type: ignore[attr-defined]


def config_of(team: Path, member: str) -> dict[str, Any]:
    config: dict[str, Any] = json.loads((team / f"{member}.json5").read_text().split("\n", 2)[2])
    return config


def test_team_keys_writes_one_private_file_per_member_and_keeps_keys(team: Path) -> None:
    described = Team.from_json((team / TEAM_FILE).read_text())
    assert described.members == {"router": Role.ROUTER, "robot1": Role.ROBOT, "robot2": Role.ROBOT,
                                 "laptop": Role.LAPTOP, "viewer": Role.VIEWER}
    assert stat.S_IMODE(team.stat().st_mode) == 0o700
    for path in team.iterdir():
        assert stat.S_IMODE(path.stat().st_mode) == 0o600, path
    for member in described.members:
        load_config_file(team / f"{member}.json5")  # Zenoh itself accepts every file
        assert member_of(team / f"{member}.json5") == (member, described.members[member])
        # the bus's link-loss settings (README, "Several machines") hold on the secured bus too
        assert config_of(team, member)["transport"]["link"]["tx"]["lease"] == LEASE_MS, member
    robot1 = config_of(team, "robot1")
    assert robot1["access_control"]["enabled"] is True and robot1["transport"]["link"]["tls"]["enable_mtls"] is True
    assert robot1["connect"]["endpoints"] == [described.router_endpoint]
    # the robot's file is its own router's: TLS to the team router, its nodes in plain TCP on loopback only
    assert robot1["mode"] == "router" and robot1["listen"]["endpoints"] == ["tcp/127.0.0.1:7447"]
    laptop, viewer = config_of(team, "laptop"), config_of(team, "viewer")
    assert laptop["mode"] == "peer" and laptop["connect"]["endpoints"] == [f"tls/127.0.0.1:{described.router_port}"]
    assert viewer["mode"] == "client" and viewer["connect"]["endpoints"] == [described.router_endpoint]
    authority = TeamAuthority.load((team / CA_KEY).read_bytes(), (team / CA_CERTIFICATE).read_bytes())
    assert authority.certificate_pem == (team / CA_CERTIFICATE).read_bytes()

    # running it again does not replace the team's keys: refused, unless --add (keys kept) or --force
    ca = (team / CA_CERTIFICATE).read_bytes()
    refused = subprocess.run([sys.executable, "-m", "pitchside.cli", "team-keys", str(team), "--team", "Other",
                              "--robots", "robot1"], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert refused.returncode == 2 and "already holds the team 'Test Team'" in refused.stderr
    assert (team / CA_CERTIFICATE).read_bytes() == ca
    robot1_key = read_credentials(team / "robot1.json5").key_pem
    robot1_file = (team / "robot1.json5").read_bytes()
    add_members(team, robots=["robot3"])
    assert read_credentials(team / "robot1.json5").key_pem == robot1_key
    assert member_of(team / "robot3.json5") == ("robot3", Role.ROBOT)
    assert "robot-robot3" in (team / "laptop.json5").read_text()  # every file that checks robots names the new one
    add_members(team, laptops=["laptop2"])
    assert "laptop2" in (team / "router.json5").read_text()
    assert (team / "robot1.json5").read_bytes() == robot1_file  # a robot's file names only the team router
    # a robot's file from before the robots ran their own routers (a peer of the team router): --rewrite keeps
    # its key and writes it as the robot's router
    robot2_key = read_credentials(team / "robot2.json5").key_pem
    (team / "robot2.json5").write_text(edited_file(team, "robot2", mode="peer").read_text())
    rewritten = subprocess.run([sys.executable, "-m", "pitchside.cli", "team-keys", str(team), "--rewrite"],
                               cwd=REPO, capture_output=True, text=True, timeout=60)
    assert rewritten.returncode == 0, rewritten.stderr
    notes = {line.split()[0]: line.split()[-1] for line in rewritten.stdout.splitlines() if line.startswith("  ")}
    assert notes["robot2.json5"] == "(rewritten)" and notes["robot1.json5"] == notes["router.json5"] == "(unchanged)"
    assert config_of(team, "robot2")["mode"] == "router"
    assert read_credentials(team / "robot2.json5").key_pem == robot2_key
    with pytest.raises(TeamKeysError, match="already a member"):
        add_members(team, robots=["robot2"])
    with pytest.raises(TeamKeysError, match="must be 1-32 characters"):
        add_members(team, viewers=["a/b"])  # a name goes into key expressions: no '/', no '*'
    with pytest.raises(TeamKeysError, match="1-12 characters"):
        add_members(team, robots=["robot-of-13ch"])  # a robot's id must also fit a telemetry header
    create_team(team, "Other", ["robotA"], force=True)
    assert (team / CA_CERTIFICATE).read_bytes() != ca
    assert not (team / "robot1.json5").exists()  # the old team's files are gone with its CA


def test_unauthenticated_sessions_cannot_publish_motor_goals(team: Path, router: zenoh.Session) -> None:
    robot1 = robot_router(team, "robot1")
    cm730 = robot_process(robot1)  # robot1's servo node
    hcm = robot_process(robot1)  # robot1's HCM, the one writer of motor_goals
    inbox = ControlInbox(cm730)
    wait_for(lambda: linked_to_team_router(robot1, router), timeout=10, what="robot1's router linked to the team's")
    endpoint = Team.from_json((team / TEAM_FILE).read_text()).router_endpoint
    ca = json.loads(load_config_file(team / "robot1.json5").get_json("transport/link/tls/root_ca_certificate_base64"))
    stranger = TeamAuthority.create("Strangers").issue("robot1", "robot")  # right name, wrong CA
    refused_at_connect: dict[str, dict[str, Any]] = {
        "plain TCP": {"connect": {"endpoints": [endpoint.replace("tls/", "tcp/")]}},
        "TLS without a certificate": {"connect": {"endpoints": [endpoint]},
                                      "transport": {"link": {"tls": {"root_ca_certificate_base64": ca}}}},
        "another CA's robot1": {"connect": {"endpoints": [endpoint]}, "transport": {"link": {"tls": {
            "root_ca_certificate_base64": ca, "connect_private_key_base64": _b64(stranger.key_pem),
            "connect_certificate_base64": _b64(stranger.certificate_pem)}}}},
    }
    for how, settings in refused_at_connect.items():
        conf = zenoh.Config.from_json5(json.dumps({"mode": "client", "scouting": {"multicast": {"enabled": False}},
                                                   **settings}))
        with pytest.raises(zenoh.ZError):
            zenoh.open(conf)
        # as a peer it opens anyway (peers keep trying), alone: what it publishes reaches nobody
        conf.insert_json5("mode", '"peer"')
        conf.insert_json5("connect/timeout_ms", "500")
        conf.insert_json5("connect/exit_on_failure", "false")
        with zenoh.open(conf) as outsider:
            assert not outsider.info.routers_zid() and not outsider.info.peers_zid(), how
            outsider.put(MOTOR_GOALS, goals(how))
    publisher = hcm.declare_publisher(MOTOR_GOALS)
    wait_matched(publisher, "the HCM sees the servo node's subscription")
    publisher.put(goals("hcm"))
    wait_for(lambda: "hcm" in inbox.senders("motor_goals"), timeout=10, what="the HCM's motor goals")
    assert inbox.senders("motor_goals") == ["hcm"]
    cm730.close()
    hcm.close()
    robot1.close()


@pytest.mark.parametrize("mode", ["peer", "client"])
def test_members_may_steer_only_what_the_access_control_allows(team: Path, router: zenoh.Session, mode: str) -> None:
    """Robots behind their own routers, the laptop and the viewer as peers or clients of the team router: what
    comes from another machine is checked where it enters the team router."""
    robot1 = robot_router(team, "robot1")
    cm730 = robot_process(robot1)
    inbox = ControlInbox(cm730)
    sessions = []
    # robot2 (even with the access control deleted from its router's file) may not write robot1's keys, its own yes
    robot2_router = robot_router(team, "robot2", access_control=False)
    try:
        robot2 = robot_process(robot2_router)
        laptop = member_session(team, "laptop", mode)
        viewer = member_session(team, "viewer", mode, access_control=False)
        sessions += [robot2, laptop, viewer]
        robot2_goals, robot2_own = robot2.declare_publisher(MOTOR_GOALS), robot2.declare_publisher(
            keys.topic_key("robot2", "motor_goals"))
        laptop_goals, laptop_cmd = laptop.declare_publisher(MOTOR_GOALS), laptop.declare_publisher(CMD_VEL)
        viewer_goals, viewer_cmd = viewer.declare_publisher(MOTOR_GOALS), viewer.declare_publisher(CMD_VEL)
        for publisher in (robot2_goals, robot2_own, laptop_goals, laptop_cmd, viewer_goals, viewer_cmd):
            wait_matched(publisher, "robot1's subscriptions seen by every member")

        viewer_goals.put(goals("viewer"))
        viewer_cmd.put(drive("viewer"))
        robot2_goals.put(goals("robot2"))
        robot2_own.put(goals("robot2-own"))  # same session, after the refused one: cannot overtake it
        laptop_goals.put(goals("laptop"))
        laptop_cmd.put(drive("laptop"))  # the lab laptop may drive, not set servo goals
        wait_for(lambda: inbox.senders("robot2") and inbox.senders("cmd_vel"), timeout=10,
                 what="the allowed messages")
        hcm = robot_process(robot1)
        sessions.append(hcm)
        hcm_goals = hcm.declare_publisher(MOTOR_GOALS)
        wait_matched(hcm_goals, "robot1's own processes see each other")
        hcm_goals.put(goals("hcm"))
        wait_for(lambda: inbox.senders("motor_goals"), timeout=10, what="robot1's own motor goals")
        assert inbox.senders("robot2") == ["robot2-own"]
        assert inbox.senders("cmd_vel") == ["laptop"]
        assert inbox.senders("motor_goals") == ["hcm"]
    finally:
        for session in sessions:
            session.close()
        cm730.close()
        robot2_router.close()
        robot1.close()


def test_a_robot_hears_only_the_team_router_not_one_posing_as_it(team: Path, router: zenoh.Session) -> None:
    """A router with another member's certificate (robot2's key, the team CA's signature) at an address robot1's
    router connects to, as after a spoofed address at the venue: linked, but neither heard nor served."""
    impostor_port = free_port()
    impostor = zenoh.open(router_config([f"tls/127.0.0.1:{impostor_port}"], None, edited_file(
        team, "robot2", access_control={"enabled": False}, connect={"endpoints": []})))
    endpoint = Team.from_json((team / TEAM_FILE).read_text()).router_endpoint
    robot1 = start_machine_router([f"tcp/127.0.0.1:{free_port()}"], [endpoint, f"tls/127.0.0.1:{impostor_port}"],
                                  team / "robot1.json5")
    sessions = []
    try:
        cm730, hcm, laptop = robot_process(robot1), robot_process(robot1), member_session(team, "laptop")
        sessions += [cm730, hcm, laptop]
        inbox = ControlInbox(cm730)
        wait_for(lambda: {str(impostor.info.zid()), str(router.info.zid())} <= {
            str(z) for z in robot1.session.info.routers_zid()}, timeout=10, what="robot1's router linked to both")
        joint_states_key = keys.topic_key("robot1", "joint_states")
        seen: dict[str, list[int]] = {"laptop": [], "impostor": []}
        laptop.declare_subscriber(joint_states_key, lambda _: seen["laptop"].append(1))
        impostor.declare_subscriber(joint_states_key, lambda _: seen["impostor"].append(1))
        joint_states, laptop_cmd = hcm.declare_publisher(joint_states_key), laptop.declare_publisher(CMD_VEL)
        state = schemas.encode(schemas.make("sensor_msgs/msg/JointState", name=["HeadPan"], position=[0.0]))

        def one_round() -> bool:
            impostor.put(MOTOR_GOALS, goals("robot2"))
            impostor.put(CMD_VEL, drive("outsider"))
            joint_states.put(state)
            laptop_cmd.put(drive("laptop"))
            return len(seen["laptop"]) >= 10 and len(inbox.senders("cmd_vel")) >= 10

        wait_for(one_round, timeout=20, interval=0.05, what="robot1 and the laptop exchanging data")
        assert seen["impostor"] == []
        assert inbox.senders("motor_goals") == [] and set(inbox.senders("cmd_vel")) == {"laptop"}
    finally:
        for session in sessions:
            session.close()
        robot1.close()
        impostor.close()


def test_a_node_works_through_the_secured_router_and_only_the_laptop_sets_its_parameters(team: Path) -> None:
    team_port = Team.from_json((team / TEAM_FILE).read_text()).router_port
    robot_port = free_port()
    cli = [sys.executable, "-m", "pitchside.cli"]
    router = subprocess.Popen([*cli, "router", "--zenoh-config", str(team / "router.json5")], cwd=REPO,
                              stderr=subprocess.PIPE, text=True)
    # robot1's router from robot1's file, its node a plain peer of it on loopback (as `pitchside robot` runs them)
    robot = subprocess.Popen([*cli, "router", "--zenoh-config", str(team / "robot1.json5"), "--listen",
                              f"tcp/127.0.0.1:{robot_port}"], cwd=REPO, stderr=subprocess.PIPE, text=True)
    talker = subprocess.Popen([sys.executable, "-m", "tests.proc_nodes", "talker", "--robot-id", "robot1",
                               "--connect", f"tcp/127.0.0.1:{robot_port}", "--set", "rate_hz=50"], cwd=REPO)
    sessions: list[zenoh.Session] = []
    try:
        assert router.stderr is not None and robot.stderr is not None
        line = router.stderr.readline()
        assert f"listening on tls/127.0.0.1:{team_port} (access control on)" in line, line
        line = robot.stderr.readline()
        assert f"listening on tcp/127.0.0.1:{robot_port} (access control on)" in line, line
        laptop, viewer, robot2 = (member_session(team, m) for m in ("laptop", "viewer", "robot2"))
        sessions += [laptop, viewer, robot2]
        labels: list[str] = []
        laptop.declare_subscriber(keys.topic_key("robot1", "joint_states"), lambda s: labels.append(
            schemas.decode(s.payload.to_bytes(), "sensor_msgs/msg/JointState").header.frame_id))
        wait_for(lambda: labels, timeout=20, what="the node's joint_states at the laptop")
        lab = ParameterClient(laptop, "robot1", timeout=10)
        lab.set("talker", {"label": "tuned"})
        wait_for(lambda: labels[-1] == "tuned", timeout=10, what="the laptop's parameter applied")
        for refused in (viewer, robot2):  # the node answers a query at once: no answer is a refusal
            with pytest.raises(ParameterError, match="did not answer"):
                ParameterClient(refused, "robot1", timeout=1.0).set("talker", {"label": "hijacked"})
        assert lab.get("talker", "label") == "tuned"
        assert "hijacked" not in labels
    finally:
        for session in sessions:
            session.close()
        for proc in (talker, robot, router):
            proc.terminate()
        talker.wait(15)
        assert robot.wait(15) == 0
        assert router.wait(15) == 0


@pytest.mark.slow
def test_the_simulated_servo_node_moves_only_for_its_own_robot(team: Path, router: zenoh.Session) -> None:
    from robot_nodes.cm730.node import Cm730Node

    robot1 = robot_router(team, "robot1")
    robot2_router = robot_router(team, "robot2", access_control=False)
    node = Cm730Node(robot_id="robot1", bus=BusConfig(connect=[robot1.local_endpoint]),
                     overrides={"publish_rate": 100.0})
    node.start()
    sessions: list[zenoh.Session] = []
    try:
        laptop, robot2, hcm = member_session(team, "laptop"), robot_process(robot2_router), robot_process(robot1)
        sessions += [laptop, robot2, hcm]
        head_pan: list[float] = []

        def on_joint_states(sample: zenoh.Sample) -> None:
            state = schemas.decode(sample.payload.to_bytes(), "sensor_msgs/msg/JointState")
            head_pan.append(float(state.position[list(state.name).index("HeadPan")]))

        laptop.declare_subscriber(keys.topic_key("robot1", "joint_states"), on_joint_states)
        wait_for(lambda: len(head_pan) > 10, timeout=20, what="joint_states at the laptop")
        forged, own = robot2.declare_publisher(MOTOR_GOALS), hcm.declare_publisher(MOTOR_GOALS)
        for publisher in (forged, own):
            wait_matched(publisher, "the servo node's subscription")

        def head_pan_goal(position: float) -> bytes:
            point = schemas.make("trajectory_msgs/msg/JointTrajectoryPoint", positions=[position])
            return schemas.encode(schemas.make("trajectory_msgs/msg/JointTrajectory", joint_names=["HeadPan"],
                                               points=[point]))

        forged.put(head_pan_goal(0.6))
        own.put(head_pan_goal(-0.4))
        wait_for(lambda: abs(head_pan[-1] + 0.4) < 0.05, timeout=20, what="HeadPan at the HCM's goal")
        assert node.goals_applied == 1
        assert max(head_pan) < 0.1, "the head turned towards robot2's goal"
    finally:
        for session in sessions:
            session.close()
        node.shutdown()
        robot2_router.close()
        robot1.close()


def test_pitchside_robot_runs_its_own_router_from_its_team_file(team: Path, router: zenoh.Session) -> None:
    from pitchside import robot as robot_command
    from pitchside.robot import robot_id_for

    assert robot_id_for(None, str(team / "robot2.json5")) == "robot2"
    with pytest.raises(SystemExit, match="robot2's team config, not robot1's"):
        robot_id_for("robot1", str(team / "robot2.json5"))
    with pytest.raises(SystemExit, match=r"laptop \(laptop\), not of a robot"):
        robot_id_for(None, str(team / "laptop.json5"))
    with pytest.raises(SystemExit, match="older `pitchside team-keys`"):
        robot_id_for(None, str(edited_file(team, "robot1", mode="peer")))  # the robot's file before routers
    assert robot_id_for(None, None) == "robot1"

    def started(match: bool, listen: str) -> MachineRouter:
        return robot_command.robot_router(argparse.Namespace(match=match, zenoh_config=str(team / "robot1.json5"),
                                                     connect=None, listen=[listen]))

    lab = started(False, f"tcp/127.0.0.1:{free_port()}")
    try:
        assert lab.connect == [Team.from_json((team / TEAM_FILE).read_text()).router_endpoint]
        wait_for(lambda: linked_to_team_router(lab, router), timeout=10, what="robot1's router at the team router")
    finally:
        lab.close()
    match = started(True, f"tcp/127.0.0.1:{free_port()}")
    try:
        assert match.connect == []  # in a match the file's endpoint is dropped: the bus stays on the robot
    finally:
        match.close()
    # the nodes join in plain TCP: the robot's router never listens for them beyond loopback
    with pytest.raises(SystemExit, match=r"beyond loopback only with TLS, not on tcp/0\.0\.0\.0:"):
        started(False, f"tcp/0.0.0.0:{free_port()}")
    plain = BusConfig().settings()  # without a team file: no TLS, no access control
    assert "tls" not in plain["transport"]["link"] and "access_control" not in plain


def test_pitchside_robot_with_its_team_file_reports_to_the_laptop(team: Path, router: zenoh.Session) -> None:
    """`pitchside robot --zenoh-config robot1.json5`: its router from the file, its nodes on loopback without it."""
    robot = subprocess.Popen([sys.executable, "-m", "pitchside.cli", "robot", "--zenoh-config",
                              str(team / "robot1.json5"), "--listen", f"tcp/127.0.0.1:{free_port()}",
                              "--nodes", "pause"], cwd=REPO)
    laptop = member_session(team, "laptop")
    try:
        paused: list[bytes] = []
        laptop.declare_subscriber(keys.topic_key("robot1", "paused"), lambda s: paused.append(s.payload.to_bytes()))
        wait_for(lambda: paused, timeout=30, what="robot1's pause node at the laptop")
    finally:
        laptop.close()
        robot.terminate()
        assert robot.wait(15) == 0


def _b64(data: bytes) -> str:
    import base64

    return base64.b64encode(data).decode("ascii")


def test_a_router_open_to_the_network_without_access_control_says_so(team: Path) -> None:
    """`pitchside router --listen tcp/0.0.0.0:...` (the lab's plain setup) lets anyone who reaches it publish
    motor_goals: the router says so when it starts, and a team's secured router has nothing to warn about."""
    cli = [sys.executable, "-m", "pitchside.cli", "router"]
    for args, warned in ((["--listen", f"tcp/0.0.0.0:{free_port()}"], True),
                         (["--listen", f"tcp/127.0.0.1:{free_port()}"], False),
                         (["--zenoh-config", str(team / "router.json5"), "--listen", f"tls/0.0.0.0:{free_port()}"],
                          False)):
        router = subprocess.Popen([*cli, *args], cwd=REPO, stderr=subprocess.PIPE, text=True)
        try:
            assert router.stderr is not None
            lines = [router.stderr.readline()]
            while "Zenoh router listening on" not in lines[-1]:
                assert lines[-1], lines  # (an empty line: the router ended)
                lines.append(router.stderr.readline())
            said = "".join(lines)
            assert ("without access control: anyone who reaches it may publish motor_goals" in said) is warned, said
        finally:
            router.terminate()
            router.wait(15)


def test_no_member_but_the_robot_writes_any_topic_of_it(team: Path, router: zenoh.Session) -> None:
    """Not only motor_goals and cmd_vel: every topic of the table (motor_torque, head and walk goals, animation,
    paused, gamestate, ...) sent to robot1 by another robot, by a viewer (both with the rules deleted from their
    files) or by the lab laptop is dropped at the team router, except the two the laptop may send."""
    robot1 = robot_router(team, "robot1")
    node = robot_process(robot1)
    got: list[tuple[str, str]] = []
    lock = threading.Lock()

    def on_sample(sample: zenoh.Sample) -> None:
        _, topic = keys.split_topic_key(str(sample.key_expr))
        with lock:
            got.append((topic, sample.attachment.to_string() if sample.attachment is not None else "?"))

    subscriber = node.declare_subscriber(keys.topic_key("robot1", "**"), on_sample)
    robot2_router = robot_router(team, "robot2", access_control=False)
    sessions: list[zenoh.Session] = []
    try:
        senders = {"robot2": robot_process(robot2_router), "viewer": member_session(team, "viewer",
                                                                                   access_control=False),
                   "laptop": member_session(team, "laptop")}
        sessions += senders.values()
        # the topics in robot1's namespace (a root topic such as /rosout is every robot's: robot2 may write it)
        publishers = {(who, t): session.declare_publisher(keys.topic_key("robot1", t))
                      for who, session in senders.items() for t, entry in schemas.TOPICS.items() if not entry.root}
        for (who, t), publisher in publishers.items():
            wait_matched(publisher, f"robot1's subscription seen by {who} ({t})")
        for (who, _), publisher in publishers.items():
            publisher.put(b"\x00\x01\x00\x00", attachment=who)  # bytes are enough: the router drops by key

        def laptop_heard() -> bool:  # after everything else the laptop sent, on the same session
            publishers[("laptop", "cmd_vel")].put(b"\x00\x01\x00\x00", attachment="laptop-last")
            with lock:
                return ("cmd_vel", "laptop-last") in got

        wait_for(laptop_heard, 10.0, 0.2, "the laptop's last cmd_vel")
        with lock:
            heard = {(t, who) for t, who in got if who != "laptop-last"}
        assert heard <= {("cmd_vel", "laptop"), ("record_motor_goals", "laptop")}, sorted(heard)
    finally:
        subscriber.undeclare()
        for session in sessions:
            session.close()
        robot2_router.close()
        node.close()
        robot1.close()


class Describing(Node):
    """A robot node with a latched topic, a topic and /rosout, as every pitchside node on rmw_zenoh's wire."""

    __test__ = False
    name = "describer"

    def setup(self) -> None:
        self.publisher("robot_description").publish(schemas.make("std_msgs/msg/String", data="<robot name='r1'/>"))
        self.joint_states = self.publisher("joint_states")
        self.timer(lambda: self.joint_states.publish(schemas.make("sensor_msgs/msg/JointState", name=["a"])),
                   rate_hz=20.0)


def test_a_member_lists_the_graph_and_receives_what_it_subscribes_to_even_everything(team: Path,
                                                                                    router: zenoh.Session) -> None:
    """What ``ros2 topic list`` and ``ros2 topic echo`` do on a member's machine, with the member's own file: the
    graph's liveliness tokens by query and by subscriber, a topic, a latched topic that was published before the
    member came (transient local: a query of the publisher's cache) and, the trap of a layout the rules did not
    follow, everything at once (``**``)."""
    robot1 = robot_router(team, "robot1")
    node = Describing("robot1", robot_process(robot1)).start()
    viewer = member_session(team, "viewer")
    late = None
    try:
        wait_for(lambda: linked_to_team_router(robot1, router), timeout=20, what="robot1's router linked")
        graph = keys.graph_tokens_key()

        def listed() -> set[str]:
            return {str(reply.ok.key_expr) for reply in viewer.liveliness().get(graph, timeout=2.0)
                    if reply.ok is not None}

        wait_for(lambda: any("/MP/%/%robot1/describer/%robot1%joint_states/" in t for t in listed()), timeout=20,
                 what="robot1's publisher token in the viewer's liveliness query")
        tokens: list[str] = []
        watcher = viewer.liveliness().declare_subscriber(graph, lambda s: tokens.append(str(s.key_expr)), history=True)
        wait_for(lambda: any("/NN/%/%robot1/describer" in t for t in tokens), timeout=20,
                 what="the node's token at the viewer's liveliness subscriber")
        everything: list[str] = []
        star = viewer.declare_subscriber("**", lambda s: everything.append(str(s.key_expr)))
        wait_for(lambda: keys.topic_key("robot1", "joint_states") in everything, timeout=20,
                 what="robot1's joint_states at a member's subscriber of **")
        described: list[zenoh.Sample] = []
        late = zenoh.ext.declare_advanced_subscriber(
            viewer, keys.topic_key("robot1", "robot_description"), described.append,
            history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=1))
        wait_for(lambda: described, timeout=20, what="the latched robot_description at a member that came late")
        assert schemas.decode(described[0].payload.to_bytes(), "std_msgs/msg/String").data == "<robot name='r1'/>"
        watcher.undeclare()
        star.undeclare()
    finally:
        if late is not None:
            late.undeclare()
        viewer.close()
        node.shutdown()
        robot1.close()
