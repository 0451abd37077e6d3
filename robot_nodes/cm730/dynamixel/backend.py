"""DynamixelBackend: the real servo bus (Protocol 1.0 through a CM-730, or Protocol 2.0) as a ServoBackend."""

from __future__ import annotations

import contextlib
import math
import termios
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import serial
from dynamixel_sdk import COMM_SUCCESS, PacketHandler

from ..backend import BusReading, ImuReading
from . import models as units
from .config import BusConfig, JointConfig
from .control_table import CM730, CM730_ID, P1, P2
from .health import BusHealth, describe_status_error
from .imu import CM730Imu
from .models import ServoModel
from .sdk_adapter import BusPort, P1BulkRead, P2SyncRead, StatusBatch, read_one

# what the serial layer raises when the adapter goes away (USB unplugged, pty closed)
PORT_ERRORS = (serial.SerialException, OSError, termios.error)


class DynamixelError(RuntimeError):
    """The bus cannot be used at all (port missing, baud rate unsupported)."""


@dataclass(slots=True)
class _Servo:
    name: str
    index: int
    cfg: JointConfig
    model: ServoModel
    silent: bool = False
    last_probe: float = 0.0


class DynamixelBackend:
    """Reads and commands all servos of one bus; one read() = one bulk/sync read, one write = one sync write.

    Silent servos are found by individual reads when they drop out of a broadcast read, left out of
    the broadcast reads afterwards (a silent MX stalls the rest of a P1 bulk-read chain) and asked
    again every `reprobe_interval_s`. Calls are serialised by an internal lock, so a timer and a
    subscription callback may share one backend.
    """

    def __init__(self, config: BusConfig) -> None:
        self.config = config
        self.protocol = config.protocol
        self.joint_names: list[str] = list(config.joints)
        self._servos = [_Servo(n, i, jc, jc.servo_model()) for i, (n, jc) in enumerate(config.joints.items())]
        self._by_name = {s.name: s for s in self._servos}
        self._by_id = {s.cfg.id: s for s in self._servos}
        self._cm730 = config.protocol == 1 and config.cm730
        self._cm730_silent = False
        self._cm730_last_probe = 0.0
        self.health_counters = BusHealth(self.joint_names)
        self._lock = threading.Lock()
        self._torque: dict[str, bool] = {}
        self._closed = False
        self._port_lost: float | None = None  # monotonic time of the loss / the last reopen attempt
        self._servo_power: bool | None = None
        n = len(self._servos)
        self._pos = np.zeros(n)
        self._vel = np.zeros(n)
        self._eff = np.zeros(n)
        self._temp = np.full(n, np.nan)
        self._servo_voltage = np.full(n, np.nan)
        self._voltage: float | None = None
        self.buttons: dict[str, bool] = {"mode": False, "start": False}
        self._imu = CM730Imu(gain=config.imu_gain)
        self._cycle = 0
        self._reads: dict[bool, Any] = {}
        self._reads_version = -1
        self._active_version = 0
        self.ph = PacketHandler(float(config.protocol))
        self.port = BusPort(config.port)
        try:
            if not self.port.setBaudRate(config.baudrate):
                raise DynamixelError(f"baud rate {config.baudrate} not supported by the port driver")
        except PORT_ERRORS as exc:
            raise DynamixelError(f"cannot open servo bus {config.port!r}: {exc}") from None
        if self._cm730:
            self._power_on()

    @classmethod
    def from_config(cls, port: str, protocol: int = 1, baudrate: int = 1_000_000,
                    joints: dict[str, JointConfig] | None = None, **options: Any) -> DynamixelBackend:
        """port e.g. /dev/ttyUSB0; joints default to the 20 Bit-Bots joints on ids 1..20; options: BusConfig fields."""
        return cls(BusConfig(port=port, protocol=protocol, baudrate=baudrate, joints=dict(joints or {}), **options))

    @classmethod
    def from_yaml(cls, path: Path, section: str = "cm730", port: str | None = None) -> DynamixelBackend:
        config = BusConfig.from_yaml(path, section)
        if port is not None:
            config.port = port
        return cls(config)

    # ------------------------------------------------------------------ reading

    def read(self) -> BusReading:
        """One cycle. Never raises for bus trouble: silent devices, garbage and a lost port end up in
        `missing` and `health()`; a lost port is reopened every `reprobe_interval_s`."""
        with self._lock:
            if self._closed:
                raise DynamixelError("read() on a closed DynamixelBackend")
            t0 = time.perf_counter()
            self._cycle += 1
            slow = self._cycle % self.config.slow_read_every == 0
            answered: set[int] = set()
            imu = None
            if self._port_lost is None or self._reopen():
                try:
                    batch = self._broadcast_read(slow)
                    self._absorb(batch, slow, answered)
                    self._find_silent(batch, slow, answered)
                    self._reprobe(slow, answered)
                    imu = self._cm730_imu(batch.data.get(CM730_ID)) if self._cm730 else None
                except PORT_ERRORS as exc:
                    self._lose_port(exc)
            missing = [s.name for s in self._servos if s.cfg.id not in answered]
            self.health_counters.end_cycle(missing, time.perf_counter() - t0)
            self.health_counters.silent = [s.name for s in self._servos if s.silent]
            if not self._cm730:
                volts = self._servo_voltage[np.isfinite(self._servo_voltage)]
                self._voltage = round(float(volts.mean()), 2) if volts.size else None
            return BusReading(positions=self._pos.copy(), velocities=self._vel.copy(), efforts=self._eff.copy(),
                              imu=imu, temperatures=self._temp.copy(), voltage=self._voltage, missing=missing)

    def _lose_port(self, exc: BaseException) -> None:
        self.port.is_using = False
        if self._port_lost is None:
            every = self.config.reprobe_interval_s
            self.health_counters.note(f"servo bus port lost ({exc}); reopening every {every} s")
        self._port_lost = time.monotonic()

    def _reopen(self) -> bool:
        """After losing the port (USB unplugged, adapter reset): try to open it again now and then."""
        if self._port_lost is None or time.monotonic() - self._port_lost < self.config.reprobe_interval_s:
            return False
        self._port_lost = time.monotonic()
        try:
            with contextlib.suppress(Exception):
                self.port.closePort()
            if not self.port.setBaudRate(self.config.baudrate):
                return False
        except PORT_ERRORS:
            return False
        self._port_lost = None
        self.health_counters.note("servo bus port reopened")
        if self._cm730:
            self._power_on()
        return True

    def _block(self, slow: bool) -> tuple[int, int]:
        table = P1 if self.protocol == 1 else P2
        return table.SLOW_BLOCK if slow else table.FAST_BLOCK

    def _broadcast_read(self, slow: bool) -> StatusBatch:
        """One BULK_READ (P1, CM-730 first, like the Darwin framework) or SYNC_READ (P2) of every live device."""
        if self._reads_version != self._active_version:
            self._reads = {flag: self._make_read(flag) for flag in (False, True)}
            self._reads_version = self._active_version
        group = self._reads[slow]
        if group is None:
            return StatusBatch()
        result = group.txPacket()
        if result != COMM_SUCCESS:
            self.port.is_using = False
            self.health_counters.tx_failures += 1
            self.health_counters.note(f"broadcast read not sent: {self.ph.getTxRxResult(result)}")
            return StatusBatch(timed_out=True)
        batch: StatusBatch = group.receive()
        self.health_counters.corrupt_packets += batch.corrupt
        if batch.timed_out:
            self.health_counters.timeouts += 1
        return batch

    def _make_read(self, slow: bool) -> P1BulkRead | P2SyncRead | None:
        address, length = self._block(slow)
        live = [s.cfg.id for s in self._servos if not s.silent]
        if self.protocol == 1:
            group = P1BulkRead(self.port, self.ph)
            if self._cm730 and not self._cm730_silent:
                group.addParam(CM730_ID, *CM730.BLOCK)
            for dxl_id in live:
                group.addParam(dxl_id, address, length)
            return group if group.data_dict else None
        sync = P2SyncRead(self.port, self.ph, address, length)
        for dxl_id in live:
            sync.addParam(dxl_id)
        return sync if sync.data_dict else None

    def _absorb(self, batch: StatusBatch, slow: bool, answered: set[int]) -> None:
        for dxl_id, data in batch.data.items():
            servo = self._by_id.get(dxl_id)
            if servo is None:
                continue
            self._decode_servo(servo, data, slow)
            answered.add(dxl_id)
            if dxl_id not in batch.errors:
                self.health_counters.servo_ok(servo.name)
        for dxl_id, err in batch.errors.items():
            self.health_counters.servo_error(self._name_of(dxl_id), self.protocol, err)

    def _name_of(self, dxl_id: int) -> str:
        return "CM730" if dxl_id == CM730_ID else self._by_id[dxl_id].name

    def _decode_servo(self, s: _Servo, d: bytes, slow: bool) -> None:
        m, i = s.model, s.index
        if self.protocol == 1:
            self._pos[i] = s.cfg.servo_to_joint(units.ticks_to_servo_rad(m, d[0] | d[1] << 8))
            self._vel[i] = s.cfg.direction * units.p1_speed_to_rad_s(m, d[2] | d[3] << 8)
            self._eff[i] = s.cfg.direction * units.p1_load_to_nm(m, d[4] | d[5] << 8)
            if slow:
                self._servo_voltage[i] = d[6] / 10.0
                self._temp[i] = float(d[7])
        else:
            position = units.signed(int.from_bytes(d[6:10], "little"), 32)
            self._pos[i] = s.cfg.servo_to_joint(units.ticks_to_servo_rad(m, position))
            self._vel[i] = s.cfg.direction * units.p2_velocity_to_rad_s(m, int.from_bytes(d[2:6], "little"))
            self._eff[i] = s.cfg.direction * units.p2_load_to_nm(m, d[0] | d[1] << 8)
            if slow:
                self._servo_voltage[i] = (d[18] | d[19] << 8) / 10.0
                self._temp[i] = float(d[20])

    def _read_single(self, dxl_id: int, slow: bool) -> StatusBatch:
        """READ of one device; one retry when the answer came garbled (alive, just unlucky)."""
        address, length = CM730.BLOCK if dxl_id == CM730_ID else self._block(slow)
        corrupt = 0
        for _ in range(2):
            batch = read_one(self.ph, self.port, dxl_id, address, length, self.config.probe_timeout_ms)
            self.health_counters.corrupt_packets += batch.corrupt
            corrupt += batch.corrupt
            if dxl_id in batch.data or not batch.corrupt:
                break
        batch.corrupt = corrupt
        return batch

    @staticmethod
    def _quiet(batch: StatusBatch, dxl_id: int) -> bool:
        """No packet at all (not even a garbled one) came back from a single READ."""
        return dxl_id not in batch.data and batch.corrupt == 0

    def _find_silent(self, batch: StatusBatch, slow: bool, answered: set[int]) -> None:
        """Devices missing from the broadcast read are asked alone; who stays quiet is marked silent."""
        now = time.monotonic()
        if self._cm730 and not self._cm730_silent and CM730_ID not in batch.data:
            single = self._read_single(CM730_ID, slow)
            if CM730_ID in single.data:
                batch.data[CM730_ID] = single.data[CM730_ID]
            elif self._quiet(single, CM730_ID):
                self._cm730_silent, self._cm730_last_probe = True, now
                self._active_version += 1
                self.health_counters.note("CM730 (id 200) silent: no IMU, buttons or bus voltage")
        for s in self._servos:
            if s.silent or s.cfg.id in answered:
                continue
            single = self._read_single(s.cfg.id, slow)
            if s.cfg.id in single.data:
                self._absorb(single, slow, answered)
            elif self._quiet(single, s.cfg.id):
                s.silent, s.last_probe = True, now
                self._active_version += 1
                self.health_counters.went_silent(s.name, s.cfg.id)

    def _reprobe(self, slow: bool, answered: set[int]) -> None:
        """Ask one silent device per cycle (the one waiting longest) whether it is back."""
        now = time.monotonic()
        interval = self.config.reprobe_interval_s
        if self._cm730 and self._cm730_silent and now - self._cm730_last_probe >= interval:
            self._cm730_last_probe = now
            if CM730_ID in self._read_single(CM730_ID, slow).data:
                self._cm730_silent = False
                self._active_version += 1
                self._power_on()
                self.health_counters.note("CM730 answers again")
            return
        due = [s for s in self._servos if s.silent and now - s.last_probe >= interval]
        if not due:
            return
        s = min(due, key=lambda x: x.last_probe)
        s.last_probe = now
        single = self._read_single(s.cfg.id, slow)
        if s.cfg.id in single.data:
            s.silent = False
            self._active_version += 1
            self._absorb(single, slow, answered)
            self.health_counters.came_back(s.name, s.cfg.id)

    def _cm730_imu(self, d: bytes | None) -> ImuReading | None:
        if d is None:
            return None

        def word(address: int) -> int:
            k = address - CM730.BLOCK[0]
            return d[k] | d[k + 1] << 8

        self._servo_power = bool(d[CM730.DYNAMIXEL_POWER - CM730.BLOCK[0]])
        b = d[CM730.BUTTONS - CM730.BLOCK[0]]
        self.buttons = {"mode": bool(b & CM730.BUTTON_MODE), "start": bool(b & CM730.BUTTON_START)}
        self._voltage = d[CM730.VOLTAGE - CM730.BLOCK[0]] / 10.0
        return self._imu.reading((word(CM730.GYRO_Z), word(CM730.GYRO_Y), word(CM730.GYRO_X)),
                                 (word(CM730.ACCEL_X), word(CM730.ACCEL_Y), word(CM730.ACCEL_Z)),
                                 time.monotonic())

    def _power_on(self) -> None:
        result, _err = self.ph.write1ByteTxRx(self.port, CM730_ID, CM730.DYNAMIXEL_POWER, 1)
        if result != COMM_SUCCESS:
            self._cm730_silent = True
            self._cm730_last_probe = time.monotonic()
            self.health_counters.note(f"CM730 power-on failed: {self.ph.getTxRxResult(result)}")

    # ------------------------------------------------------------------ writing

    def _servos_for(self, names: list[str]) -> list[_Servo]:
        unknown = [n for n in names if n not in self._by_name]
        if unknown:
            raise ValueError(f"unknown joints {unknown}; this bus has {self.joint_names}")
        return [self._by_name[n] for n in names]

    def write_goals(self, names: list[str], positions: np.ndarray,
                    velocities: np.ndarray | None = None, efforts: np.ndarray | None = None) -> None:
        """One SYNC_WRITE. P1: goal position (+ moving speed, + torque limit from efforts); P2: goal position
        (+ profile velocity); efforts are ignored on P2. Velocity 0 = no speed limit. Joints with torque
        switched off are skipped (a P1 goal write would switch their torque back on). Non-finite goals are
        skipped and counted."""
        servos = self._servos_for(list(names))
        pos = np.asarray(positions, dtype=float).reshape(-1)
        vel = None if velocities is None else np.asarray(velocities, dtype=float).reshape(-1)
        eff = None if efforts is None else np.asarray(efforts, dtype=float).reshape(-1)
        for label, arr in (("positions", pos), ("velocities", vel), ("efforts", eff)):
            if arr is not None and arr.size != len(servos):
                raise ValueError(f"{label} has {arr.size} values for {len(servos)} joints")
        if vel is not None and vel.size == 0:
            vel = None
        if eff is not None and (eff.size == 0 or self.protocol == 2):
            eff = None
        param: list[int] = []
        for k, s in enumerate(servos):
            if self._torque.get(s.name) is False:
                continue
            if not math.isfinite(pos[k]):
                self.health_counters.rejected_goals += 1
                self.health_counters.note(f"non-finite goal for {s.name} skipped")
                continue
            ticks = units.servo_rad_to_ticks(s.model, s.cfg.joint_to_servo(float(pos[k])))
            param.append(s.cfg.id)
            if self.protocol == 1:
                param += [ticks & 0xFF, ticks >> 8]
                if vel is not None or eff is not None:
                    speed = 0 if vel is None else units.rad_s_to_p1_moving_speed(s.model, float(vel[k]))
                    param += [speed & 0xFF, speed >> 8]
                if eff is not None:
                    e = float(eff[k])
                    limit = 1023 if not math.isfinite(e) else min(1023, round(abs(e) / s.model.stall_torque_nm * 1023))
                    param += [limit & 0xFF, limit >> 8]
            else:
                if vel is not None:
                    param += list(units.rad_s_to_p2_profile_velocity(s.model, float(vel[k])).to_bytes(4, "little"))
                param += list((ticks & 0xFFFFFFFF).to_bytes(4, "little"))
        if not param:
            return
        if self.protocol == 1:
            address = P1.GOAL_POSITION
            length = 2 + (2 if (vel is not None or eff is not None) else 0) + (2 if eff is not None else 0)
        else:
            address, length = (P2.PROFILE_VELOCITY, 8) if vel is not None else (P2.GOAL_POSITION, 4)
        self._sync_write(address, length, param)

    def set_torque(self, names: list[str], enabled: bool) -> None:
        servos = self._servos_for(list(names))
        address = P1.TORQUE_ENABLE if self.protocol == 1 else P2.TORQUE_ENABLE
        param: list[int] = []
        for s in servos:
            param += [s.cfg.id, 1 if enabled else 0]
            self._torque[s.name] = bool(enabled)
        if param:
            self._sync_write(address, 1, param)

    def identify(self) -> dict[str, str]:
        """Model found at each joint's id (reads the model number): 'ok', 'silent', or what is there instead.
        Worth calling once at start-up: a wrong model means wrong tick/radian conversion."""
        found: dict[str, str] = {}
        with self._lock:
            for s in self._servos:
                batch = read_one(self.ph, self.port, s.cfg.id, 0, 2, self.config.probe_timeout_ms)
                if s.cfg.id not in batch.data:
                    found[s.name] = "silent"
                    continue
                number = int.from_bytes(batch.data[s.cfg.id], "little")
                actual = units.model_by_number(self.protocol, number)
                if actual is None or actual.name != s.model.name:
                    label = actual.name if actual else f"model number {number}"
                    found[s.name] = label
                    self.health_counters.note(f"{s.name}: configured {s.model.name}, found {label}")
                else:
                    found[s.name] = "ok"
        return found

    def torque(self) -> dict[str, bool | None]:
        """Torque state as last commanded (None: never commanded by this backend)."""
        return {n: self._torque.get(n) for n in self.joint_names}

    def _sync_write(self, address: int, length: int, param: list[int]) -> None:
        with self._lock:
            if self._closed:
                raise DynamixelError("write on a closed DynamixelBackend")
            if self._port_lost is not None:
                return
            try:
                result = self.ph.syncWriteTxOnly(self.port, address, length, param, len(param))
            except PORT_ERRORS as exc:
                self._lose_port(exc)
                return
            self.port.is_using = False
            if result != COMM_SUCCESS:
                self.health_counters.tx_failures += 1
                self.health_counters.note(f"sync write at {address} failed: {self.ph.getTxRxResult(result)}")

    # ------------------------------------------------------------------ angle-limit registers

    def angle_limit_ticks(self, name: str, lower: float, upper: float) -> tuple[int, int]:
        """Register values (lowest, highest tick) for a joint-side range in rad. The conversion is the one
        write_goals uses (direction, offset, nearest tick), so every goal inside the range lands inside the
        registers; a mirrored joint's upper limit becomes the servo's lowest tick."""
        s = self._by_name[name]
        a = units.servo_rad_to_ticks(s.model, s.cfg.joint_to_servo(lower))
        b = units.servo_rad_to_ticks(s.model, s.cfg.joint_to_servo(upper))
        return min(a, b), max(a, b)

    def write_angle_limits(self, ranges: dict[str, tuple[float, float]]) -> dict[str, str]:
        """Writes the servos' own limits from joint-side ranges (rad), so a servo refuses a goal outside them
        whatever sends it: P1 CW/CCW Angle Limit (6/8), P2 Min/Max Position Limit (52/48).

        Registers already right are left alone, so a restarted node does not touch a standing robot. The
        others are EEPROM: the servo's torque goes off for the write (Protocol 2.0 refuses EEPROM writes with
        torque on; the spec asks the same of MX Protocol 1.0) and back on if it was on. Equal limits are never
        written (P1: CW = CCW = 0 is wheel mode, both 4095 multi-turn). Returns per joint 'ok' (already set),
        'written', or why not."""
        report: dict[str, str] = {}
        with self._lock:
            if self._closed:
                raise DynamixelError("write_angle_limits on a closed DynamixelBackend")
            for s in self._servos:
                if s.name not in ranges:
                    continue
                if self._port_lost is not None:
                    report[s.name] = "not written: servo bus port lost"
                    continue
                try:
                    report[s.name] = self._write_angle_limit(s, *ranges[s.name])
                except PORT_ERRORS as exc:
                    self._lose_port(exc)
                    report[s.name] = "not written: servo bus port lost"
        for name, text in report.items():
            if text not in ("ok", "written"):
                self.health_counters.note(f"{name}: angle limits {text}")
        return report

    def _write_angle_limit(self, s: _Servo, lower: float, upper: float) -> str:
        lo, hi = self.angle_limit_ticks(s.name, lower, upper)
        if lo >= hi:
            return f"not written: the range is {lo}..{hi} ticks (equal limits switch the servo out of joint mode)"
        if self.protocol == 1:
            address, torque_at = P1.CW_ANGLE_LIMIT, P1.TORQUE_ENABLE
            wanted = lo.to_bytes(2, "little") + hi.to_bytes(2, "little")
        else:
            address, torque_at = P2.MAX_POSITION_LIMIT, P2.TORQUE_ENABLE
            wanted = hi.to_bytes(4, "little") + lo.to_bytes(4, "little")
        dxl_id = s.cfg.id
        present = self._read_register(dxl_id, address, len(wanted))
        if present is None:
            return "not written: servo silent"
        if present != wanted:
            torque = self._read_register(dxl_id, torque_at, 1)
            if torque is None:
                return "not written: servo silent"
            if torque[0]:
                self._write_register(dxl_id, torque_at, b"\x00")
            refused = self._write_register(dxl_id, address, wanted)
            if torque[0]:
                self._write_register(dxl_id, torque_at, b"\x01")
            if self._read_register(dxl_id, address, len(wanted)) != wanted:
                return f"not written: {refused or 'the registers read back different'} ({lo}..{hi} ticks wanted)"
        if self.protocol == 2:
            mode = self._read_register(dxl_id, P2.OPERATING_MODE, 1)
            if mode is not None and mode[0] != 3:
                return f"set, but operating mode {mode[0]} ignores position limits (only mode 3 uses them)"
        return "ok" if present == wanted else "written"

    def _read_register(self, dxl_id: int, address: int, length: int) -> bytes | None:
        """One READ (a garbled answer is asked again once); None when the servo does not answer."""
        for _ in range(2):
            batch = read_one(self.ph, self.port, dxl_id, address, length, self.config.probe_timeout_ms)
            self.health_counters.corrupt_packets += batch.corrupt
            if dxl_id in batch.data:
                return batch.data[dxl_id]
            if not batch.corrupt:
                return None
        return None

    def _write_register(self, dxl_id: int, address: int, data: bytes) -> str:
        """One WRITE with its status packet; '' when accepted, else what the servo (or the wire) said."""
        result, error = self.ph.writeTxRx(self.port, dxl_id, address, len(data), list(data))
        self.port.is_using = False
        if result != COMM_SUCCESS:
            return f"write at {address}: {self.ph.getTxRxResult(result)}"
        if error:
            return f"write at {address}: servo reports {describe_status_error(self.protocol, error)}"
        return ""

    # ------------------------------------------------------------------ status

    def health(self) -> dict[str, Any]:
        """Counters and a one-line text for diagnostics: silent servos, misses, corrupt packets, errors."""
        with self._lock:
            report = self.health_counters.as_dict()
            report["cm730"] = "absent" if not self._cm730 else ("silent" if self._cm730_silent else "ok")
            report["servo_power"] = self._servo_power
            report["port_lost"] = self._port_lost is not None
            if self._cm730 and self._cm730_silent:
                report["ok"] = False
                report["text"] += "; CM730 silent"
            if self._port_lost is not None:
                report["ok"] = False
                report["text"] = "port lost; " + report["text"]
            report["buttons"] = dict(self.buttons)
            report["voltage"] = self._voltage
            report["port"] = self.config.port
            report["protocol"] = self.protocol
            return report

    def close(self) -> None:
        with self._lock:
            self._closed = True
            if self.port.is_open:
                with contextlib.suppress(Exception):
                    self.port.closePort()

    def __enter__(self) -> DynamixelBackend:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_backend(device: str, baudrate: int = 1_000_000, protocol: int = 1, config_yaml: str | Path | None = None,
                 **options: Any) -> DynamixelBackend:
    """What the cm730 node calls: the bus at `device`; joints and settings from `config_yaml`
    (`cm730: {dynamixel: {...}}`) if given, else the 20 Bit-Bots joints on ids 1..20 (P1: MX-64 + CM-730)."""
    if config_yaml is not None:
        config = BusConfig.from_yaml(Path(config_yaml))
        config.port, config.baudrate = device, baudrate
        return DynamixelBackend(config)
    return DynamixelBackend.from_config(device, protocol, baudrate, **options)
