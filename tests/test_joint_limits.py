"""Safe at the venue: every motor goal is clamped to the URDF joint limits, on the simulated and the emulated real bus,
and the Dynamixel servos get the same limits in their angle-limit registers, so they refuse the rest themselves."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import zenoh
from hypothesis import given, settings
from hypothesis import strategies as st

import schemas
from robot_nodes.cm730.dynamixel import BITBOTS_JOINTS, DynamixelBackend, JointConfig, default_joints
from robot_nodes.cm730.joint_limits import ClampTally, GoalLimits, JointLimitsError, read_urdf_limits
from robot_nodes.cm730.node import Cm730Node
from robot_nodes.runtime import BusConfig, open_session
from robots import ROOT as ROBOTS
from tests.servo_bus_emulator import ServoBusEmulator
from tests.support import TESTDATA
from tests.waiting import wait_for
from wire.animation import load_animation
from wire.keys import topic_key

MINIBOT_URDF = ROBOTS / "minibot" / "urdf" / "minibot.urdf"
WOLFGANG_URDF = TESTDATA / "robots" / "wolfgang" / "urdf" / "robot.urdf"
ONE_DEG = math.radians(1.0)
TICK = 2 * math.pi / 4096


def _urdf(tmp_path: Path, joints: str) -> Path:
    path = tmp_path / "robot.urdf"
    path.write_text(f'<robot name="r"><link name="a"/><link name="b"/>{joints}</robot>')
    return path


def _yourdfpy_limits(path: Path) -> dict[str, tuple[float, float, float]]:
    yourdfpy = pytest.importorskip("yourdfpy")
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=False)
    return {j.name: (j.limit.lower, j.limit.upper, j.limit.velocity) for j in urdf.robot.joints if j.type == "revolute"}


# ---------------------------------------------------------------- reading a URDF


@pytest.mark.parametrize("path", [MINIBOT_URDF, WOLFGANG_URDF], ids=["minibot", "wolfgang"])
def test_urdf_limits_equal_what_yourdfpy_reads(path: Path) -> None:
    """The stdlib reader against yourdfpy (the oracle), on our Minibot and on Bit-Bots' Wolfgang."""
    if not path.exists():
        pytest.fail(f"{path} missing")
    ours = read_urdf_limits(path)
    theirs = _yourdfpy_limits(path)
    assert set(ours) == set(theirs) == set(BITBOTS_JOINTS)
    for name, (lower, upper, velocity) in theirs.items():
        assert (ours[name].lower, ours[name].upper, ours[name].velocity) == (lower, upper, velocity), name
    # Wolfgang also has fixed cleat joints with <limit 0 0> and <transmission><joint name=...> references:
    # neither may become (or duplicate) a servo joint
    assert ours["LKnee"].lower == -0.2 and ours["RKnee"].upper == 0.2


def test_bad_urdfs_are_clear_errors(tmp_path: Path) -> None:
    with pytest.raises(JointLimitsError, match="cannot read URDF"):
        read_urdf_limits(tmp_path / "nothing.urdf")
    (tmp_path / "broken.urdf").write_text("<robot><joint name='a'")
    with pytest.raises(JointLimitsError, match="cannot read URDF"):
        read_urdf_limits(tmp_path / "broken.urdf")
    (tmp_path / "other.xml").write_text("<mujoco/>")
    with pytest.raises(JointLimitsError, match="not a URDF"):
        read_urdf_limits(tmp_path / "other.xml")
    cases = {
        '<joint name="k" type="revolute"><parent link="a"/><child link="b"/></joint>': "has no <limit>",
        '<joint name="k" type="revolute"><limit lower="1" upper="-1" velocity="1"/></joint>': "lower 1.0 is above",
        '<joint name="k" type="revolute"><limit lower="x" upper="1" velocity="1"/></joint>': "is not a number",
        '<joint name="k" type="revolute"><limit lower="nan" upper="1" velocity="1"/></joint>': "not finite",
        '<joint name="k" type="fixed"/>': "no revolute or continuous joint",
        '<joint name="k" type="continuous"/><joint name="k" type="fixed"/>': "defined twice",
    }
    for joints, message in cases.items():
        with pytest.raises(JointLimitsError, match=message):
            read_urdf_limits(_urdf(tmp_path, joints))


def test_continuous_prismatic_narrow_and_speedless_joints(tmp_path: Path) -> None:
    path = _urdf(tmp_path, '<joint name="wheel" type="continuous"><limit velocity="2"/></joint>'
                           '<joint name="slide" type="prismatic"><limit lower="0" upper="1" velocity="1"/></joint>'
                           '<joint name="narrow" type="revolute"><limit lower="0.1" upper="0.11" velocity="1"/></joint>'
                           '<joint name="free" type="revolute"><limit lower="-1" upper="1"/></joint>'
                           '<joint name="zero" type="revolute"><limit velocity="3"/></joint>')
    limits = GoalLimits.from_urdf(path, margin_deg=1.0)
    assert not limits.knows("slide")  # not a servo joint: the node refuses its goals like an unknown joint's
    assert limits.safe_range("wheel") == (-math.inf, math.inf)
    assert limits.safe_range("narrow") == pytest.approx((0.105, 0.105))  # narrower than 2 margins: its middle
    assert limits.safe_range("zero") == (0.0, 0.0)  # missing lower/upper are 0, as the URDF spec says
    names = ["wheel", "narrow", "free"]
    out = limits.clamp(names, np.array([50.0, 0.0, 3.0]), np.array([5.0, 0.0, 7.0]))
    assert out.positions.tolist() == pytest.approx([50.0, 0.105, 1.0 - ONE_DEG])  # the wheel turns on
    assert out.velocities is not None and out.velocities.tolist() == [2.0, 1.0, 7.0]  # "free" has no speed limit
    assert out.capped.tolist() == [True, False, False]
    speedless = GoalLimits.from_urdf(_urdf(tmp_path, '<joint name="f" type="revolute"><limit upper="1"/></joint>'), 1)
    assert speedless.clamp(["f"], np.array([0.5])).velocities is None  # nothing to cap: the wire stays as it was


# ---------------------------------------------------------------- the clamp


@pytest.fixture(scope="module")
def minibot() -> GoalLimits:
    return GoalLimits.from_urdf(MINIBOT_URDF, margin_deg=1.0)


def test_clamp_positions_into_the_safe_range(minibot: GoalLimits) -> None:
    names = ["HeadPan", "LKnee", "RKnee", "HeadTilt"]
    out = minibot.clamp(names, np.array([10.0, -3.0, 0.3, 0.3]))
    assert out.positions.tolist() == pytest.approx([2.35619 - ONE_DEG, -0.2 + ONE_DEG, 0.2 - ONE_DEG, 0.3])
    assert out.excess.tolist() == pytest.approx([10.0 - 2.35619 + ONE_DEG, 2.8 + ONE_DEG, 0.1 + ONE_DEG, 0.0])
    assert out.clamped.tolist() == [True, True, True, False] and out.changed


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(min_value=-1e9, max_value=1e9), min_size=20, max_size=20))
def test_no_goal_leaves_the_urdf_limits(positions: list[float]) -> None:
    limits = GoalLimits.from_urdf(MINIBOT_URDF, margin_deg=1.0)
    urdf = read_urdf_limits(MINIBOT_URDF)
    out = limits.clamp(BITBOTS_JOINTS, np.array(positions))
    for name, asked, sent in zip(BITBOTS_JOINTS, positions, out.positions, strict=True):
        assert urdf[name].lower + ONE_DEG - 1e-12 <= sent <= urdf[name].upper - ONE_DEG + 1e-12
        assert sent == asked or (asked < urdf[name].lower + ONE_DEG or asked > urdf[name].upper - ONE_DEG)


def test_speed_policy(minibot: GoalLimits) -> None:
    """Without a speed, or with 0 ("as fast as you can" to a Dynamixel), goals move at the URDF velocity."""
    names = ["LKnee", "HeadPan", "LHipPitch", "RKnee", "RHipPitch"]
    urdf = [3.87, 8.17, 5.76, 3.87, 5.76]
    assert minibot.clamp(names, np.zeros(5)).velocities.tolist() == urdf  # type: ignore[union-attr]
    out = minibot.clamp(names, np.zeros(5), np.array([0.0, 100.0, 1.0, -2.0, math.nan]))
    assert out.velocities is not None and out.velocities.tolist() == [3.87, 8.17, 1.0, 2.0, 5.76]
    assert out.capped.tolist() == [False, True, False, False, True]
    assert not out.clamped.any() and out.changed


def test_tally_counts_everything_and_reports_at_most_every_period(minibot: GoalLimits) -> None:
    tally = ClampTally(every_s=5.0)
    names = ["LKnee", "HeadPan"]
    reports = []
    for k in range(1000):  # 10 s of a bad stream at 100 Hz
        out = minibot.clamp(names, np.array([5.0 if k == 500 else 3.0, 0.0]), np.array([0.0, 50.0]))
        reports.append(tally.add(names, out, now=k * 0.01))
    said = [r for r in reports if r]
    assert len(said) == 2  # at t = 0 and t = 5 s, not a thousand lines
    assert "worst LKnee" in said[1] and "2.2" in said[1] and "capped 500 goal speed(s)" in said[1]
    assert tally.positions == {"LKnee": 1000} and tally.speeds == {"HeadPan": 1000}
    assert tally.worst_joint == "LKnee" and tally.worst_excess == pytest.approx(5.0 - 2.8 + ONE_DEG)
    assert tally.by_joint() == "LKnee=1000" and tally.worst().startswith("LKnee 2.217 rad")
    assert tally.add(names, minibot.clamp(names, np.zeros(2), np.ones(2)), now=20.0) is None  # nothing changed


def test_the_minibots_own_animations_stay_inside_the_urdf_limits(minibot: GoalLimits) -> None:
    """No keyframe leans on the clamp (a clamped stand-up would log errors after every fall): the stand-ups and
    the front fall keep their elbows and knees just inside the margin."""
    urdf = read_urdf_limits(MINIBOT_URDF)
    clamped: dict[str, dict[str, float]] = {}
    for path in sorted((ROBOTS / "minibot" / "animations").glob("*.json")):
        for keyframe in load_animation(path).keyframes:
            names = list(keyframe.goals)
            asked = np.radians([keyframe.goals[n] for n in names])
            for n, a in zip(names, asked, strict=True):
                assert urdf[n].lower - 1e-6 <= a <= urdf[n].upper + 1e-6, f"{path.stem} {n} beyond its URDF limit"
            out = minibot.clamp(names, asked)
            for i in np.flatnonzero(out.clamped).tolist():
                worst = clamped.setdefault(path.stem, {})
                worst[names[i]] = max(worst.get(names[i], 0.0), math.degrees(float(out.excess[i])))
    assert not clamped, {a: {j: round(d, 2) for j, d in js.items()} for a, js in clamped.items()}


# ---------------------------------------------------------------- the Dynamixel bus (emulated)

# mirrored and offset servos, as real robots are built
MOUNTING = {"LKnee": JointConfig(id=12, direction=-1, offset=0.1), "RKnee": JointConfig(id=18, offset=-0.2),
            "HeadPan": JointConfig(id=1, direction=-1), "LShoulderPitch": JointConfig(id=3, direction=-1, offset=0.3)}


def _joints(protocol: int) -> dict[str, JointConfig]:
    joints = default_joints(protocol)
    model = "MX-64" if protocol == 1 else "MX-64(2.0)"
    joints.update({n: JointConfig(jc.id, model, jc.direction, jc.offset) for n, jc in MOUNTING.items()})
    return joints


def _expected_ticks(jc: JointConfig, lower: float, upper: float) -> tuple[int, int]:
    """Independent of the backend: servo angle = offset + direction * joint angle, 4096 ticks a turn, centre 2048."""
    ends = sorted(round(2048 + (jc.offset + jc.direction * x) / TICK) for x in (lower + ONE_DEG, upper - ONE_DEG))
    return max(ends[0], 0), min(ends[1], 4095)


def _backend(emu: ServoBusEmulator) -> DynamixelBackend:
    # every servo answers here: a long probe timeout costs nothing, and on a loaded CI machine the emulator's thread
    # waited longer than 100 ms for the CPU once ("servo silent")
    return DynamixelBackend.from_config(emu.port, emu.protocol, 1_000_000, joints=_joints(emu.protocol),
                                        cm730=emu.protocol == 1, probe_timeout_ms=1000.0)


def _goals(names: list[str], positions: np.ndarray, velocities: np.ndarray | None = None) -> bytes:
    point = schemas.make("trajectory_msgs/msg/JointTrajectoryPoint", positions=np.asarray(positions, dtype=float),
                         velocities=np.zeros(0) if velocities is None else np.asarray(velocities, dtype=float))
    return schemas.encode(schemas.make("trajectory_msgs/msg/JointTrajectory", joint_names=names, points=[point]))


@pytest.mark.parametrize("protocol", [1, 2])
def test_out_of_limit_goals_never_reach_the_wire(protocol: int, bus: BusConfig) -> None:
    """A real cm730 node over Zenoh on the emulated bus: the registers are set at start-up (mirrored and offset
    joints included), then a storm of wild goals; every goal position any servo ever received lies inside its
    limits, so no servo ever had to refuse one, and no goal asked for the servo's unlimited speed."""
    urdf = read_urdf_limits(MINIBOT_URDF)
    with ServoBusEmulator(protocol=protocol, ids=range(1, 21)) as emu:
        node = Cm730Node(robot_id="robot1", bus=bus, backend=_backend(emu), overrides={"publish_rate": 50.0})
        node.start()
        session = open_session(bus)
        try:
            assert set(node.angle_limit_report.values()) == {"written"}, node.angle_limit_report
            joints = _joints(protocol)
            expected = {n: _expected_ticks(jc, urdf[n].lower, urdf[n].upper) for n, jc in joints.items()}
            for name, jc in joints.items():
                assert emu.servo(jc.id).angle_limits() == expected[name], name
            assert expected["LKnee"] == (round(2048 + (0.1 - 2.8 + ONE_DEG) / TICK),
                                         round(2048 + (0.1 + 0.2 - ONE_DEG) / TICK))  # mirrored: the ends swap

            names = list(BITBOTS_JOINTS)
            # BLOCK: a burst of goals must not be dropped on the way (Zenoh drops under congestion by default)
            publisher = session.declare_publisher(topic_key("robot1", "motor_goals"),
                                                  congestion_control=zenoh.CongestionControl.BLOCK)
            knee = emu.servo(12)

            def arrived(home: float) -> bool:  # sent again while waiting: the first puts may not be routed yet
                publisher.put(_goals(names, np.full(20, home)))
                return knee.goal() == round(2048 + (0.1 - home) / TICK)

            wait_for(lambda: arrived(0.05), timeout=20, interval=0.1, what="a first goal on the emulated knee")
            rng = np.random.default_rng(7)
            storm = [np.full(20, 10.0), np.full(20, -10.0), np.full(20, 1e9), np.full(20, -math.pi)]
            storm += [rng.uniform(-6.0, 6.0, 20) for _ in range(30)]
            for k, positions in enumerate(storm):
                publisher.put(_goals(names, positions, np.full(20, 100.0) if k % 2 else None))
            wait_for(lambda: arrived(0.06), timeout=20, interval=0.1, what="the goal after the storm")
            for name, jc in joints.items():
                servo = emu.servo(jc.id)
                lo, hi = expected[name]
                assert len(servo.goal_log) >= 2, name
                outside = [g for g in servo.goal_log if not lo <= g <= hi]
                assert not outside, f"{name}: goals {outside[:5]} outside {lo}..{hi} reached the wire"
                assert servo.refused_goals == 0, name
                # speed: always the URDF velocity or less, never 0 (= unlimited)
                speed = servo.u16(32) if protocol == 1 else int.from_bytes(servo.table[112:116], "little")
                unit_rad_s = (0.114 if protocol == 1 else 0.229) * 2 * math.pi / 60
                assert 0 < speed * unit_rad_s <= urdf[name].velocity + unit_rad_s, (name, speed)
            assert node.clamps.total_positions >= 20 * 4  # at least the four all-out goals, every joint
            assert node.clamps.total_speeds >= 20
        finally:
            session.close()
            node.shutdown()


@pytest.mark.parametrize("protocol", [1, 2])
def test_the_servo_refuses_what_gets_past_the_node(protocol: int) -> None:
    """The registers are the second line: a goal written straight to the backend, past the clamp, is refused by
    the (emulated) servo. Registers already right are not written again (a restarted node does not drop a
    standing robot), and torque comes back on after an EEPROM write."""
    limits = GoalLimits.from_urdf(MINIBOT_URDF, margin_deg=1.0)
    with ServoBusEmulator(protocol=protocol, ids=range(1, 21)) as emu, _backend(emu) as backend:
        backend.set_torque(backend.joint_names, True)
        wait_for(lambda: all(emu.servo(i).torque for i in range(1, 21)), timeout=5, what="torque on")
        ranges = {n: limits.safe_range(n) for n in backend.joint_names}
        assert set(backend.write_angle_limits(ranges).values()) == {"written"}
        assert all(emu.servo(i).torque for i in range(1, 21)), "torque restored after the EEPROM write"
        assert set(backend.write_angle_limits(ranges).values()) == {"ok"}
        knee = emu.servo(12)
        before = knee.goal()
        backend.write_goals(["LKnee"], np.array([-1.0]))  # 0.8 rad beyond the knee's lower limit, past the clamp
        wait_for(lambda: knee.refused_goals == 1, timeout=5, what="the knee refusing the goal")
        assert knee.goal() == before
        if protocol == 1:  # the MX keeps saying so in its status packets
            wait_for(lambda: backend.read() and backend.health()["servo_errors"].get("LKnee") == "angle limit",
                     timeout=5, what="angle limit error in health")
        # a range of one tick would make CW = CCW (P1: wheel or multi-turn mode): never written
        report = backend.write_angle_limits({"HeadTilt": (0.0, 0.0001)})
        assert report["HeadTilt"].startswith("not written") and emu.servo(2).angle_limits() != (0, 0)
        assert emu.servo(2).angle_limits() == backend.angle_limit_ticks("HeadTilt", *ranges["HeadTilt"])


def test_protocol2_eeprom_needs_torque_off_in_the_emulator() -> None:
    """The emulator is as strict as an X-series servo, so the backend's torque-off dance is really tested."""
    with ServoBusEmulator(protocol=2, ids=[1]) as emu:
        joints = {"HeadPan": JointConfig(1, "MX-64(2.0)")}
        with DynamixelBackend.from_config(emu.port, 2, 1_000_000, joints=joints, probe_timeout_ms=100.0) as backend:
            backend.set_torque(["HeadPan"], True)
            wait_for(lambda: emu.servo(1).torque, timeout=5, what="torque on")
            result, error = backend.ph.write4ByteTxRx(backend.port, 1, 48, 3000)
            backend.port.is_using = False
            assert (result, error) == (0, 7) and emu.servo(1).angle_limits() == (0, 4095)  # access error


def test_node_without_limits_never_opens_a_real_bus(bus: BusConfig, tmp_path: Path) -> None:
    with ServoBusEmulator(protocol=1, ids=range(1, 21)) as emu:
        with pytest.raises(JointLimitsError, match=r"no joint limits, so the servo bus stays off.*cannot read URDF"):
            Cm730Node(robot_id="robot1", bus=bus, overrides={"backend": "dynamixel", "device": emu.port,
                                                           "urdf": str(tmp_path / "missing.urdf")})
        with pytest.raises(JointLimitsError, match="not a folder name"):
            Cm730Node(robot_id="robot1", bus=bus, overrides={"backend": "dynamixel", "device": emu.port,
                                                           "model": "../../etc"})
        assert emu.cm730 is not None and not emu.cm730.power  # the servos were never even switched on
        assert all(not emu.servo(i).goal_log for i in range(1, 21))


# ---------------------------------------------------------------- the simulated robot


class Diagnostics:
    """The cm730 node's diagnostics values as they arrive over Zenoh."""

    def __init__(self, session: zenoh.Session) -> None:
        self.values: dict[str, str] = {}
        self._lock = threading.Lock()
        self._sub = session.declare_subscriber(topic_key("robot1", "diagnostics"), self._on)

    def _on(self, sample: zenoh.Sample) -> None:
        msg = schemas.decode(sample.payload.to_bytes(), "diagnostic_msgs/msg/DiagnosticArray")
        for status in msg.status:
            if status.name == "robot1/cm730":
                with self._lock:
                    self.values = {kv.key: kv.value for kv in status.values}

    def get(self, key: str) -> str | None:
        with self._lock:
            return self.values.get(key)

    def close(self) -> None:
        self._sub.undeclare()


@pytest.fixture
def sim_node(bus: BusConfig, request: pytest.FixtureRequest) -> Iterator[Cm730Node]:
    overrides: dict[str, Any] = {"publish_rate": 100.0, "render_camera": False, **getattr(request, "param", {})}
    node = Cm730Node(robot_id="robot1", bus=bus, overrides=overrides)
    node.start()
    yield node
    node.shutdown()


@pytest.mark.slow
@pytest.mark.parametrize("sim_node", [{"limit_margin_deg": 5.0}], indirect=True)
def test_simulated_robot_is_clamped_and_diagnostics_count(sim_node: Cm730Node, client: zenoh.Session) -> None:
    """MuJoCo clips to the URDF limits by itself; the node's clamp holds the head 5 deg inside them."""
    diagnostics = Diagnostics(client)
    publisher = client.declare_publisher(topic_key("robot1", "motor_goals"))
    backend: Any = sim_node.backend
    head_pan = sim_node.joint_names.index("HeadPan")
    safe = 2.35619 - math.radians(5.0)
    try:
        assert sim_node.goal_limits is not None
        wait_for(lambda: publisher.put(_goals(["HeadPan"], np.array([4.0]))) or
                 abs(float(backend.read().positions[head_pan]) - safe) < 0.01, timeout=30, interval=0.1,
                 what="HeadPan held 5 deg inside its limit (MuJoCo alone would stop 5 deg further)")
        wait_for(lambda: int(diagnostics.get("clamped_goals") or 0) >= 1, timeout=10, what="clamp count")
        assert (diagnostics.get("clamped_goals_by_joint") or "").startswith("HeadPan=")
        assert (diagnostics.get("worst_clamp") or "").startswith("HeadPan 1.")  # 4.0 - (2.356 - 5 deg) rad
        assert "20 joints clamped 5 deg inside their limits" in (diagnostics.get("joint_limits") or "")
        assert "clamped" in sim_node.last_error and "worst HeadPan" in sim_node.last_error
        # a steady stream of bad goals (every 10 ms, as the HCM sends them): each one counted, one error line per 5 s
        errors, count, start = sim_node.errors, sim_node.clamps.total_positions, time.monotonic()
        wait_for(lambda: publisher.put(_goals(["HeadPan"], np.array([4.0]))) or
                 sim_node.clamps.total_positions >= count + 100, timeout=30, what="a stream of 100 clamps counted")
        assert sim_node.errors - errors <= 1 + (time.monotonic() - start) // 5.0
    finally:
        diagnostics.close()


@pytest.mark.slow
@pytest.mark.parametrize("sim_node", [{"urdf": "/nonexistent/robot.urdf"}], indirect=True)
def test_simulation_starts_without_limits_but_says_so(sim_node: Cm730Node, client: zenoh.Session) -> None:
    assert sim_node.goal_limits is None
    assert "no joint limits, goals are not clamped (simulation only)" in sim_node.last_error
    publisher = client.declare_publisher(topic_key("robot1", "motor_goals"))
    wait_for(lambda: publisher.put(_goals(["HeadPan"], np.array([0.3]))) or sim_node.goals_applied > 0, timeout=20,
             interval=0.1, what="goals applied by the simulated robot")

