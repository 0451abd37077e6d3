"""Dynamixel backend against the real dynamixel-sdk talking to a servo-bus emulator on a pseudo-terminal."""

from __future__ import annotations

import inspect
import math
import os
import time
import tty
from collections.abc import Iterator
from importlib.metadata import version
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from dynamixel_sdk import GroupBulkRead, PacketHandler, PortHandler, Protocol1PacketHandler
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import schemas
from robot_nodes.cm730.dynamixel import (
    BITBOTS_JOINTS,
    BusConfig,
    ConfigError,
    DynamixelBackend,
    DynamixelError,
    JointConfig,
    default_joints,
    joints_from_dict,
    open_backend,
)
from robot_nodes.cm730.dynamixel import models as units
from robot_nodes.cm730.dynamixel.imu import CM730Imu, ComplementaryFilter, accel_raw, gyro_raw, world_up_in_body
from robot_nodes.cm730.dynamixel.sdk_adapter import P1BulkRead
from robot_nodes.cm730.node import Cm730Node
from robot_nodes.runtime import BusConfig as RuntimeBus
from robot_nodes.runtime import open_session
from tests.servo_bus_emulator import CORRUPTIONS, ServoBusEmulator, crc16, p1_packet, p2_packet, stuff, unstuff
from tests.waiting import wait_for
from wire.keys import topic_key

MX64 = units.model("MX-64")
TICK = MX64.rad_per_tick


@pytest.fixture
def bus1() -> Iterator[ServoBusEmulator]:
    with ServoBusEmulator(protocol=1, ids=range(1, 21)) as emu:
        yield emu


@pytest.fixture
def bus2() -> Iterator[ServoBusEmulator]:
    with ServoBusEmulator(protocol=2, ids=range(1, 21)) as emu:
        yield emu


def backend_on(emu: ServoBusEmulator, **options: object) -> DynamixelBackend:
    options.setdefault("probe_timeout_ms", 100.0)  # generous: the emulator shares a loaded machine
    return DynamixelBackend.from_config(emu.port, emu.protocol, 1_000_000, **options)  # type: ignore[arg-type]


# ---------------------------------------------------------------- units and configuration


def test_ticks_radians_with_offset_and_direction() -> None:
    assert units.ticks_to_servo_rad(MX64, 2048) == 0.0
    assert units.ticks_to_servo_rad(MX64, 3072) == pytest.approx(math.pi / 2)
    assert units.servo_rad_to_ticks(MX64, -math.pi / 2) == 1024
    assert units.servo_rad_to_ticks(MX64, 10.0) == 4095  # clamped, never wrapped
    assert units.servo_rad_to_ticks(MX64, -10.0) == 0
    with pytest.raises(ValueError):
        units.servo_rad_to_ticks(MX64, math.nan)
    mirrored = JointConfig(id=3, direction=-1, offset=0.2)
    for joint in (-1.0, 0.0, 0.7):
        servo = mirrored.joint_to_servo(joint)
        assert servo == pytest.approx(0.2 - joint)
        assert mirrored.servo_to_joint(servo) == pytest.approx(joint)
        ticks = units.servo_rad_to_ticks(MX64, servo)
        assert abs(mirrored.servo_to_joint(units.ticks_to_servo_rad(MX64, ticks)) - joint) <= TICK / 2
    ax = units.model("AX-12")  # 1024 ticks over 300 deg, centre 512
    assert units.ticks_to_servo_rad(ax, 1023) == pytest.approx(math.radians(150) * 511 / 512)


def test_speed_and_load_encodings() -> None:
    assert units.p1_signed_magnitude(100) == 100
    assert units.p1_signed_magnitude(1024 + 100) == -100
    assert units.p1_speed_to_rad_s(MX64, 1024 + 1) == pytest.approx(-0.114 * 2 * math.pi / 60)
    assert units.rad_s_to_p1_moving_speed(MX64, 0.0) == 0  # 0 = no limit
    assert units.rad_s_to_p1_moving_speed(MX64, 1e-6) == 1  # tiny but non-zero must not become 'no limit'
    assert units.rad_s_to_p1_moving_speed(MX64, 1e6) == 1023
    assert units.signed(0xFFFFFFFD, 32) == -3
    assert units.signed(0x7FFF, 16) == 32767
    x2 = units.model("MX-64(2.0)")
    assert units.p2_load_to_nm(x2, 0xFFFF) < 0


def test_default_mapping_and_config_loading(tmp_path: Path) -> None:
    joints = default_joints()
    assert list(joints) == list(BITBOTS_JOINTS) and len(joints) == 20
    assert [j.id for j in joints.values()] == list(range(1, 21))
    path = tmp_path / "params.yaml"
    path.write_text("cm730:\n  dynamixel:\n    port: /dev/ttyUSB1\n    protocol: 2\n    baudrate: 2000000\n"
                    "    joints:\n      LKnee: {id: 12, model: XH540-W270, direction: -1, offset_deg: 90}\n")
    config = BusConfig.from_yaml(path)
    assert config.port == "/dev/ttyUSB1" and config.protocol == 2
    assert config.joints["LKnee"] == JointConfig(id=12, model="XH540-W270", direction=-1, offset=math.pi / 2)
    with pytest.raises(ConfigError, match="share servo id"):
        BusConfig(joints={"A": JointConfig(1), "B": JointConfig(1)})
    with pytest.raises(ConfigError, match="direction"):
        BusConfig(joints={"A": JointConfig(1, direction=2)})
    with pytest.raises(ConfigError, match="protocol"):
        BusConfig(protocol=2, joints={"A": JointConfig(1, model="MX-64")})
    with pytest.raises(ValueError, match="unknown servo model"):
        BusConfig(joints={"A": JointConfig(1, model="MX-9000")})
    with pytest.raises(ConfigError, match="CM-730"):
        BusConfig(joints={"A": JointConfig(200)})
    with pytest.raises(ConfigError, match="unknown keys"):
        joints_from_dict({"A": {"id": 1, "ofset": 0.1}})


def test_complementary_filter_finds_tilt_and_cm730_scaling() -> None:
    f = ComplementaryFilter(gain=0.05)
    f.update(np.zeros(3), np.array([0.0, 0.0, 9.81]), 0.0)
    accel = np.array([2.0, -3.0, 9.0])
    for _ in range(300):
        q = f.update(np.zeros(3), accel, 0.01)
    assert np.allclose(world_up_in_body(q), accel / np.linalg.norm(accel), atol=1e-3)
    imu = CM730Imu()
    reading = imu.reading((gyro_raw(0.5), 512, gyro_raw(-1.0)), (512, 512, accel_raw(9.80665)), 0.0)
    assert reading.angular_velocity == pytest.approx([-1.0, 0.0, 0.5], abs=0.03)  # words are Z, Y, X
    assert reading.linear_acceleration == pytest.approx([0.0, 0.0, 9.80665], abs=0.05)


def test_emulator_packets_match_the_protocol_examples() -> None:
    assert p1_packet(1, 0, bytes([0x00, 0x08])).hex(" ") == "ff ff 01 04 00 00 08 f2"
    assert p2_packet(1, bytes([0x01])).hex(" ") == "ff ff fd 00 01 03 00 01 19 4e"
    assert p2_packet(1, bytes([0x02, 0x84, 0, 4, 0])).hex(" ") == "ff ff fd 00 01 07 00 02 84 00 04 00 1d 15"
    assert crc16(bytes.fromhex("fffffd00010300 01".replace(" ", ""))) == 0x4E19
    body = bytes([0x55, 0, 0xFF, 0xFF, 0xFD, 0x01])
    assert stuff(body) == bytes([0x55, 0, 0xFF, 0xFF, 0xFD, 0xFD, 0x01])
    assert unstuff(stuff(body)) == body


def test_adapter_puts_the_spec_packets_on_the_wire() -> None:
    """The bytes the backend's bulk read and sync write send equal the worked examples of the protocol spec."""
    master, slave = os.openpty()
    tty.setraw(slave)
    port = PortHandler(os.ttyname(slave))
    assert port.openPort()
    try:
        ph = PacketHandler(1.0)
        bulk = P1BulkRead(port, ph)
        bulk.addParam(200, 24, 30)
        bulk.addParam(1, 36, 6)
        bulk.addParam(2, 36, 6)
        assert bulk.txPacket() == 0
        port.is_using = False
        assert os.read(master, 64).hex(" ") == "ff ff fe 0c 92 00 1e c8 18 06 01 24 06 02 24 0e"
        assert ph.syncWriteTxOnly(port, 30, 2, [1, 0x00, 0x08, 2, 0x00, 0x04], 6) == 0
        assert os.read(master, 64).hex(" ") == "ff ff fe 0a 83 1e 02 01 00 08 02 00 04 45"
    finally:
        port.closePort()
        os.close(master)
        os.close(slave)


# ---------------------------------------------------------------- the SDK bug canary


def test_sdk_groupbulkread_protocol1_bug_still_present(bus1: ServoBusEmulator) -> None:
    """FAILS when dynamixel-sdk fixes or changes GroupBulkRead for Protocol 1.0: then revisit sdk_adapter.P1BulkRead."""
    assert version("dynamixel-sdk") == "4.1.0", "dynamixel-sdk changed: re-check the P1 bulk-read workaround"
    assert list(inspect.signature(Protocol1PacketHandler.bulkReadTx).parameters) == ["self", "port", "param",
                                                                                      "param_length"]
    port = PortHandler(bus1.port)
    assert port.openPort()
    try:
        stock = GroupBulkRead(port, PacketHandler(1.0))
        stock.addParam(1, 36, 2)
        with pytest.raises(TypeError):
            stock.txPacket()  # 4.1.0 passes fast_option, which the P1 handler does not take
        port.is_using = False
        bus1.cm730.table[24] = 1  # type: ignore[union-attr]
        adapter = P1BulkRead(port, PacketHandler(1.0))
        adapter.addParam(1, 36, 2)
        assert adapter.txPacket() == 0
        assert 1 in adapter.receive().data
    finally:
        port.closePort()


@pytest.mark.parametrize("protocol", [1, 2])
def test_sdk_ping_and_model_check(protocol: int) -> None:
    """The SDK's own ping (P1: PING + READ of address 0) works against the emulator; identify() finds the models."""
    with ServoBusEmulator(protocol=protocol, ids=range(1, 21), cm730=False) as emu:
        emu.servo(12).model_number = 320 if protocol == 1 else 321
        emu.servo(12).put(0, emu.servo(12).model_number, 2)
        emu.silence(20)
        joints = default_joints(protocol)
        joints["LKnee"] = JointConfig(id=12, model="MX-106" if protocol == 1 else "MX-106(2.0)")
        joints["LHipPitch"] = JointConfig(id=11, model="MX-28" if protocol == 1 else "MX-28(2.0)")  # wrong
        with backend_on(emu, joints=joints, cm730=False, probe_timeout_ms=50.0) as backend:
            model_number, result, error = backend.ph.ping(backend.port, 3)
            assert (model_number, result, error) == (310 if protocol == 1 else 311, 0, 0)
            found = backend.identify()
            assert found["LKnee"] == "ok" and found["HeadPan"] == "ok"
            assert found["LHipPitch"] == ("MX-64" if protocol == 1 else "MX-64(2.0)")
            assert found["RAnkleRoll"] == "silent"


# ---------------------------------------------------------------- Protocol 1.0 + CM-730


def test_reads_positions_imu_and_buttons(bus1: ServoBusEmulator) -> None:
    bus1.servo(3).position = 2048 + 512  # LShoulderPitch at +45 deg
    bus1.cm730.set_imu(gyro_xyz=(gyro_raw(1.0), 512, 512), accel_xyz=(512, 512, accel_raw(9.80665)))  # type: ignore[union-attr]
    bus1.cm730.set_buttons(start=True)  # type: ignore[union-attr]
    with backend_on(bus1) as backend:
        assert bus1.cm730.power  # type: ignore[union-attr]
        reading = backend.read()
        assert reading.missing == []
        assert reading.positions[2] == pytest.approx(math.pi / 4, abs=TICK)
        assert reading.imu is not None
        assert reading.imu.angular_velocity[0] == pytest.approx(1.0, abs=0.03)
        assert reading.imu.linear_acceleration[2] == pytest.approx(9.81, abs=0.05)
        assert reading.voltage == pytest.approx(12.2)
        assert backend.buttons == {"mode": False, "start": True}

        def temperatures() -> list[float] | None:
            t = backend.read().temperatures
            return list(t) if t is not None and not np.isnan(t).any() else None

        assert wait_for(temperatures, timeout=10, what="temperatures from a slow read") == [36.0] * 20


def test_write_goals_with_offsets_directions_and_speed(bus1: ServoBusEmulator) -> None:
    joints = default_joints()
    joints["LKnee"] = JointConfig(id=12, model="MX-106", direction=-1, offset=0.1)
    with backend_on(bus1, joints=joints) as backend:
        backend.set_torque(backend.joint_names, True)
        goals = np.linspace(-0.5, 0.5, 20)
        backend.write_goals(backend.joint_names, goals, velocities=np.full(20, 2.0))
        knee = backend.joint_names.index("LKnee")
        expected = units.servo_rad_to_ticks(MX64, 0.1 - goals[knee])
        wait_for(lambda: bus1.servo(12).goal() == expected, timeout=5, what="knee goal ticks")
        assert bus1.servo(1).goal() == units.servo_rad_to_ticks(MX64, goals[0])
        assert bus1.servo(1).u16(32) == units.rad_s_to_p1_moving_speed(MX64, 2.0)
        wait_for(lambda: np.allclose(backend.read().positions, goals, atol=3 * TICK), timeout=10,
                 what="present positions reach the goals")
        backend.write_goals(["LKnee"], np.array([0.0]), efforts=np.array([4.2]))  # half of an MX-106's stall torque
        wait_for(lambda: bus1.servo(12).u16(34) == 512, timeout=5, what="torque limit from the effort")
        assert bus1.servo(12).u16(32) == 0  # no velocity given: no speed limit


def test_torque_off_and_bad_input(bus1: ServoBusEmulator) -> None:
    with backend_on(bus1) as backend:
        backend.set_torque(backend.joint_names, True)
        wait_for(lambda: all(bus1.servo(i).torque for i in range(1, 21)), timeout=5, what="torque on")
        backend.set_torque(["HeadPan"], False)
        wait_for(lambda: not bus1.servo(1).torque, timeout=5, what="HeadPan torque off")
        backend.write_goals(["HeadPan", "HeadTilt"], np.array([0.4, 0.4]))
        wait_for(lambda: bus1.servo(2).goal() != 2048, timeout=5, what="HeadTilt goal")
        assert not bus1.servo(1).torque and bus1.servo(1).goal() == 2048  # a goal would have re-enabled torque
        with pytest.raises(ValueError, match="unknown joints"):
            backend.write_goals(["Tail"], np.array([0.0]))
        with pytest.raises(ValueError, match="2 values for 1 joints"):
            backend.write_goals(["HeadTilt"], np.array([0.0, 1.0]))
        backend.write_goals(["HeadTilt"], np.array([math.nan]))
        assert backend.health()["rejected_goals"] == 1
        wait_for(lambda: backend.read().missing == [], timeout=5, what="all servos answering")
    with pytest.raises(DynamixelError, match="closed"):
        backend.read()


def test_servo_error_bits_reach_health(bus1: ServoBusEmulator) -> None:
    with backend_on(bus1) as backend:
        bus1.servo(4).error = 0x04 | 0x20  # overheating, overload
        wait_for(lambda: backend.read() and "LShoulderRoll" in backend.health()["servo_errors"], timeout=5,
                 what="error bits reported")
        assert backend.health()["servo_errors"]["LShoulderRoll"] == "overheating, overload"
        bus1.servo(4).error = 0
        wait_for(lambda: backend.read() and not backend.health()["servo_errors"], timeout=5, what="error cleared")


def test_open_backend_as_the_node_calls_it(bus1: ServoBusEmulator, tmp_path: Path) -> None:
    with open_backend(device=bus1.port, baudrate=1_000_000) as backend:
        assert backend.joint_names == list(BITBOTS_JOINTS)
        wait_for(lambda: backend.read().missing == [], timeout=5, what="all 20 servos")
    path = tmp_path / "params.yaml"
    path.write_text("cm730:\n  dynamixel:\n    protocol: 1\n    probe_timeout_ms: 100\n    joints:\n"
                    "      HeadPan: {id: 1}\n      HeadTilt: {id: 2, direction: -1}\n")
    with open_backend(device=bus1.port, config_yaml=path) as backend:
        assert backend.joint_names == ["HeadPan", "HeadTilt"]
        assert backend.read().missing == []


def test_missing_port_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(DynamixelError, match="cannot open"):
        DynamixelBackend.from_config(str(tmp_path / "ttyUSB9"), 1, 1_000_000)


def test_loop_rate_at_emulated_1mbaud(bus1: ServoBusEmulator) -> None:
    """Full read+write cycles; bench/dynamixel.py measures the figure, this only guards against collapse."""
    with backend_on(bus1) as backend:
        backend.set_torque(backend.joint_names, True)
        goals = np.zeros(20)
        backend.read()
        n, t0 = 100, time.perf_counter()
        for _ in range(n):
            reading = backend.read()
            backend.write_goals(backend.joint_names, goals)
        rate = n / (time.perf_counter() - t0)
        assert reading.missing == []
        assert rate >= 50.0, f"only {rate:.0f} Hz"


def test_silent_servo_is_reported_and_others_keep_updating(bus1: ServoBusEmulator) -> None:
    with backend_on(bus1, reprobe_interval_s=0.2) as backend:
        backend.set_torque(backend.joint_names, True)
        backend.read()
        bus1.silence(5)  # LElbow
        name = BITBOTS_JOINTS[4]
        t0 = time.monotonic()
        missing = wait_for(lambda: backend.read().missing, timeout=5, what="a missing joint")
        assert missing == [name]
        assert time.monotonic() - t0 < 1.0
        health = backend.health()
        assert health["silent"] == [name] and not health["ok"] and name in health["text"]
        # the rest of the chain still answers: ids after the silent one move to new goals
        goals = np.full(20, 0.6)
        backend.write_goals(backend.joint_names, goals)
        others = [i for i in range(20) if i != 4]

        def others_arrived() -> bool:
            r = backend.read()
            return r.missing == [name] and np.allclose(r.positions[others], 0.6, atol=3 * TICK)

        wait_for(others_arrived, timeout=10, what="the other 19 servos following their goals")
        bus1.silence(5, False)
        wait_for(lambda: backend.read().missing == [] and backend.health()["silent"] == [], timeout=5,
                 what="the servo coming back after a re-probe")


def test_silent_cm730_and_lost_port(bus1: ServoBusEmulator) -> None:
    with backend_on(bus1, reprobe_interval_s=0.2) as backend:
        assert backend.read().imu is not None and backend.health()["servo_power"] is True
        bus1.silence(200)
        wait_for(lambda: backend.read().imu is None and backend.health()["cm730"] == "silent", timeout=5,
                 what="CM-730 reported silent")
        reading = backend.read()
        assert reading.missing == [] and reading.imu is None  # the servos still answer
        assert "CM730 silent" in backend.health()["text"]
        bus1.silence(200, False)
        wait_for(lambda: backend.read().imu is not None and backend.health()["cm730"] == "ok", timeout=5,
                 what="CM-730 back")
        bus1.stop()  # the USB adapter disappears
        wait_for(lambda: len(backend.read().missing) == 20, timeout=5, what="every joint missing without a port")
        backend.write_goals(backend.joint_names, np.zeros(20))  # no exception either
        health = backend.health()
        assert health["port_lost"] and not health["ok"] and "port lost" in health["text"]


@pytest.mark.parametrize("kind", CORRUPTIONS)
def test_corrupted_status_packets_are_counted_never_crash(bus1: ServoBusEmulator, kind: str) -> None:
    with backend_on(bus1) as backend:
        backend.read()
        for dxl_id in (1, 7, 20, 200):
            bus1.corrupt(dxl_id, kind, count=2)
        wait_for(lambda: backend.read() and bus1.pending_corruptions() == 0, timeout=10,
                 what="all garbled packets sent")
        assert backend.health()["corrupt_packets"] >= 1
        wait_for(lambda: backend.read().missing == [] and backend.read().imu is not None, timeout=5,
                 what="a clean read after the corruption")
        assert bus1.stats["corrupted"] == 8
        assert backend.health()["silent"] == []  # garbled is not silent


# random bytes mixed with header fragments, so the parsers also see plausible-looking packet starts
_HEADERS = [b"\xff\xff", b"\xff\xff\xfd\x00", b"\xff\xff\x01\xfa", b"\xff\xff\xfd\x00\x05\xff\x00"]
_noise = st.lists(st.one_of(st.binary(max_size=40), st.sampled_from(_HEADERS)), max_size=4).map(b"".join)


@pytest.mark.parametrize("protocol", [1, 2])
def test_line_noise_never_crashes(protocol: int) -> None:
    """Random bytes ahead of the status packets (hypothesis): read() returns, garbage is counted or skipped."""
    with ServoBusEmulator(protocol=protocol, ids=range(1, 7)) as emu:
        joints = {name: jc for name, jc in default_joints(protocol).items() if jc.id <= 6}
        with backend_on(emu, joints=joints, reprobe_interval_s=0.05, probe_timeout_ms=20.0) as backend:

            @settings(max_examples=40, deadline=None, suppress_health_check=list(HealthCheck))
            @given(noise=_noise)
            def one_read(noise: bytes) -> None:
                emu.inject(noise)
                reading = backend.read()
                assert reading.positions.shape == (6,) and set(reading.missing) <= set(joints)

            one_read()
            wait_for(lambda: backend.read().missing == [], timeout=10, what="all servos after the noise")


# ---------------------------------------------------------------- Protocol 2.0


def test_protocol2_read_write_and_byte_stuffing(bus2: ServoBusEmulator) -> None:
    with backend_on(bus2) as backend:
        assert backend.health()["cm730"] == "absent"
        reading = backend.read()
        assert reading.missing == [] and reading.imu is None
        backend.set_torque(backend.joint_names, True)
        wait_for(lambda: bus2.servo(20).torque, timeout=5, what="P2 torque on")
        goals = np.linspace(-1.0, 1.0, 20)
        backend.write_goals(backend.joint_names, goals, velocities=np.full(20, 3.0))
        wait_for(lambda: np.allclose(backend.read().positions, goals, atol=3 * TICK), timeout=10,
                 what="P2 positions reach the goals")
        x2 = units.model("MX-64(2.0)")
        assert int.from_bytes(bus2.servo(1).table[112:116], "little") == units.rad_s_to_p2_profile_velocity(x2, 3.0)
        # load -1, velocity -3: the status packet contains FF FF FD and must be byte-stuffed
        bus2.servo(9).overrides = {126: b"\xff\xff", 128: (-3 & 0xFFFFFFFF).to_bytes(4, "little")}
        reading = backend.read()
        assert reading.missing == []
        assert reading.velocities[8] == pytest.approx(units.p2_velocity_to_rad_s(x2, 0xFFFFFFFD))
        assert reading.efforts[8] < 0


def test_protocol2_silent_servo_and_corruption(bus2: ServoBusEmulator) -> None:
    with backend_on(bus2, reprobe_interval_s=0.2) as backend:
        backend.read()
        bus2.silence(2)
        wait_for(lambda: backend.read().missing == ["HeadTilt"], timeout=5, what="P2 silent servo")
        bus2.corrupt(10, "checksum")
        bus2.corrupt(11, "length_long")
        for _ in range(5):
            backend.read()
        assert backend.health()["corrupt_packets"] >= 2
        bus2.silence(2, False)
        wait_for(lambda: backend.read().missing == [], timeout=5, what="P2 servo back")


# ---------------------------------------------------------------- the cm730 node on the emulated bus


def test_cm730_node_drives_the_emulated_bus(bus1: ServoBusEmulator, bus: RuntimeBus) -> None:
    """The node, as launched with backend=dynamixel, over a real Zenoh router: joint_states out, motor_goals in."""
    node = Cm730Node(robot_id="robot1", bus=bus, overrides={"backend": "dynamixel", "device": bus1.port,
                                                          "publish_rate": 50.0}).start()
    session = open_session(bus)
    states: list[Any] = []
    sub = session.declare_subscriber(topic_key("robot1", "joint_states"),
                                     lambda s: states.append(schemas.decode(s.payload.to_bytes(),
                                                                            "sensor_msgs/msg/JointState")))
    goals = session.declare_publisher(topic_key("robot1", "motor_goals"))
    try:
        bus1.servo(2).position = 2048 + 300
        wait_for(lambda: states and abs(states[-1].position[1] - 300 * TICK) < 2 * TICK, timeout=20,
                 what="HeadTilt in joint_states")
        point = schemas.make("trajectory_msgs/msg/JointTrajectoryPoint", positions=np.array([0.5]))
        msg = schemas.make("trajectory_msgs/msg/JointTrajectory", joint_names=["HeadPan"], points=[point])
        wait_for(lambda: goals.put(schemas.encode(msg)) or bus1.servo(1).goal() == 2048 + round(0.5 / TICK),
                 timeout=20, interval=0.2, what="HeadPan goal on the emulated servo")
    finally:
        sub.undeclare()
        session.close()
        node.shutdown()


def test_cm730_node_publishes_servo_health(bus1: ServoBusEmulator, bus: RuntimeBus) -> None:
    """servo_health (what the HCM's HARDWARE_PROBLEM comes from): who is silent and the bus state, at once on a
    change and every second, from the real protocol on the emulated bus."""
    bus_state = schemas.constants("pitchside_msgs/msg/ServoHealth")
    node = Cm730Node(robot_id="robot1", bus=bus, backend=backend_on(bus1, reprobe_interval_s=0.2),
                     overrides={"publish_rate": 50.0}).start()
    session = open_session(bus)
    health: list[tuple[float, Any]] = []
    sub = session.declare_subscriber(topic_key("robot1", "servo_health"), lambda s: health.append(
        (time.monotonic(), schemas.decode(s.payload.to_bytes(), schemas.topic("servo_health").type))))

    def first_since(t0: float, want: Any) -> Any:
        return next((h for t, h in list(health) if t > t0 and want(h)), None)

    try:
        wait_for(lambda: sum(h.bus_state == bus_state["BUS_OK"] and not list(h.missing_servos) for _, h in health)
                 >= 2, timeout=10, what="servo_health every second, every servo answering")
        silent_joint = BITBOTS_JOINTS[4]
        t0 = time.monotonic()
        bus1.silence(5)
        silent = wait_for(lambda: first_since(t0, lambda h: list(h.missing_servos)), timeout=10,
                          what="a silent servo on servo_health")
        assert list(silent.missing_servos) == [silent_joint] and silent.bus_state == bus_state["BUS_DEGRADED"]
        assert silent_joint in silent.description and silent.header.stamp.sec > 0
        t1 = time.monotonic()
        bus1.silence(5, False)
        wait_for(lambda: first_since(t1, lambda h: h.bus_state == bus_state["BUS_OK"] and not list(h.missing_servos)),
                 timeout=10, what="the servo back on servo_health")
        t2 = time.monotonic()
        bus1.silence(200)  # the CM-730 board: every servo still answers, the bus is not whole
        board = wait_for(lambda: first_since(t2, lambda h: h.bus_state == bus_state["BUS_DEGRADED"]), timeout=10,
                         what="the silent CM-730 on servo_health")
        assert not list(board.missing_servos) and "CM730 silent" in board.description
        t3 = time.monotonic()
        bus1.stop()  # the USB adapter disappears
        lost = wait_for(lambda: first_since(t3, lambda h: h.bus_state == bus_state["BUS_LOST"]), timeout=10,
                        what="the lost port on servo_health")
        assert len(lost.missing_servos) == 20 and "port lost" in lost.description
    finally:
        sub.undeclare()
        session.close()
        node.shutdown()
