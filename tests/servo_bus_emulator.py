"""A Dynamixel servo bus on a pseudo-terminal: Protocol 1.0 (MX servos + CM-730) or 2.0, real packet formats.

The real dynamixel-sdk opens `emulator.port` (the pty's slave side) with PortHandler; this thread
answers on the master side like the devices on a half-duplex bus would. With `timing=True` the bus is
occupied for 10 bit times per byte (8N1) of every instruction and status packet, so throughput at
1 Mbaud is what the wire would allow. Faults on demand: `silence(id)`, `corrupt(id, kind, count)`.

Servos keep their angle-limit registers (P1 CW/CCW 6/8, P2 min/max position 52/48) and honour them as the
manuals describe: a goal position outside them is refused (the servo keeps its old goal; P1 sets the angle-limit
error bit, P2 answers a WRITE with "data limit"); P2 refuses EEPROM writes while torque is on. Every goal
position that reaches a servo is logged in `goal_log`, refused or not, so a test can prove what was on the wire.
A refused write is not applied at all (nor the speed written with it).
"""

from __future__ import annotations

import contextlib
import math
import os
import select
import threading
import time
import tty
from collections.abc import Iterable

P1_HEADER = b"\xff\xff"
P2_HEADER = b"\xff\xff\xfd\x00"
BROADCAST = 0xFE
CM730_ID = 200
CORRUPTIONS = ("checksum", "length_long", "length_short", "short_data", "truncate")


def p1_checksum(body: bytes) -> int:
    return ~sum(body) & 0xFF


def crc16(data: bytes) -> int:
    """CRC-16/BUYPASS (poly 0x8005, init 0, not reflected), as Protocol 2.0 uses."""
    crc = 0
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else crc << 1
            crc &= 0xFFFF
    return crc


def stuff(body: bytes) -> bytes:
    out = bytearray()
    for b in body:
        out.append(b)
        if out[-3:] == b"\xff\xff\xfd":
            out.append(0xFD)
    return bytes(out)


def unstuff(body: bytes) -> bytes:
    out = bytearray()
    i = 0
    while i < len(body):
        out.append(body[i])
        if out[-3:] == b"\xff\xff\xfd" and i + 1 < len(body) and body[i + 1] == 0xFD:
            i += 1  # drop the stuffed FD
        i += 1
    return bytes(out)


def p1_packet(dxl_id: int, first: int, params: bytes) -> bytes:
    body = bytes([dxl_id, len(params) + 2, first]) + params
    return P1_HEADER + body + bytes([p1_checksum(body)])


def p2_packet(dxl_id: int, body: bytes) -> bytes:
    """body = instruction (+ error) + params, before stuffing."""
    stuffed = stuff(body)
    head = P2_HEADER + bytes([dxl_id]) + (len(stuffed) + 2).to_bytes(2, "little")
    crc = crc16(head + stuffed)
    return head + stuffed + crc.to_bytes(2, "little")


class Device:
    """A control table plus the bit of behaviour the tests need."""

    model_number = 0

    def __init__(self, dxl_id: int, size: int) -> None:
        self.id = dxl_id
        self.table = bytearray(size)
        self.silent = False
        self.corruptions: list[str] = []
        self.overrides: dict[int, bytes] = {}  # address -> bytes forced after every update
        self.error = 0  # error byte of every status packet

    def tick(self, now: float) -> None:
        for address, data in self.overrides.items():
            self.table[address:address + len(data)] = data

    def read(self, address: int, length: int) -> bytes | None:
        if address + length > len(self.table):
            return None
        return bytes(self.table[address:address + length])

    def write(self, address: int, data: bytes) -> bool:
        if address + len(data) > len(self.table):
            return False
        self.table[address:address + len(data)] = data
        return True

    def refuses(self, address: int, data: bytes) -> int:
        """The status error a WRITE of these bytes gets instead of being applied (0: accepted)."""
        return 0

    def alarm(self) -> int:
        """Error bits the device keeps setting in its status packets (P1), until the cause goes away."""
        return 0

    def u16(self, address: int) -> int:
        return self.table[address] | self.table[address + 1] << 8

    def put(self, address: int, value: int, size: int) -> None:
        self.table[address:address + size] = (value & ((1 << (8 * size)) - 1)).to_bytes(size, "little")


class CM730Device(Device):
    """CM-730 sub-controller: Dynamixel power switch, buttons, IMU words and supply voltage."""

    model_number = 0x7300

    def __init__(self) -> None:
        super().__init__(CM730_ID, 80)
        self.put(0, self.model_number, 2)
        self.table[2] = 0x14
        self.table[3] = CM730_ID
        self.table[4] = 1
        self.set_imu(gyro_xyz=(512, 512, 512), accel_xyz=(512, 512, 640))  # at rest: +1 g on z
        self.table[50] = 122

    @property
    def power(self) -> bool:
        return bool(self.table[24])

    def set_imu(self, gyro_xyz: tuple[int, int, int], accel_xyz: tuple[int, int, int]) -> None:
        gx, gy, gz = gyro_xyz
        for address, value in ((38, gz), (40, gy), (42, gx), (44, accel_xyz[0]), (46, accel_xyz[1]),
                               (48, accel_xyz[2])):
            self.put(address, value, 2)

    def set_buttons(self, mode: bool = False, start: bool = False) -> None:
        self.table[30] = (1 if mode else 0) | (2 if start else 0)


class MXServo(Device):
    """MX servo: present position follows the goal as a first-order lag (time constant `tau`)."""

    protocol = 1
    # Protocol 1.0 table (MX-28/64/106)
    TORQUE, GOAL, SPEED_LIMIT, POS, SPEED, LOAD, VOLT, TEMP = 24, 30, 32, 36, 38, 40, 42, 43
    GOAL_SIZE = 2
    speed_unit_rpm = 0.114

    def __init__(self, dxl_id: int, model_number: int = 310, tau: float = 0.03, start_ticks: int = 2048) -> None:
        super().__init__(dxl_id, 256 if self.protocol == 2 else 74)
        self.model_number = model_number
        self.goal_log: list[int] = []  # every goal position written to this servo, in order, refused ones too
        self.refused_goals = 0  # goals outside the angle limits, not applied
        self.angle_limit_error = False  # the last goal was outside the limits (P1 status bit 1)
        self.tau = tau
        self.position = float(start_ticks)
        self.velocity = 0.0  # ticks/s
        self.voltage_dv = 121
        self.temperature = 36
        self._last = time.monotonic()
        self._init_table(start_ticks)

    def _init_table(self, start_ticks: int) -> None:
        self.put(0, self.model_number, 2)
        self.table[2], self.table[3], self.table[4] = 0x24, self.id, 1
        self.put(8, 4095, 2)
        self.put(14, 1023, 2)
        self.table[16] = 2
        self.put(34, 1023, 2)
        self.put(self.GOAL, start_ticks, self.GOAL_SIZE)
        self.tick(time.monotonic())

    @property
    def torque(self) -> bool:
        return bool(self.table[self.TORQUE])

    def goal(self) -> int:
        return int.from_bytes(self.table[self.GOAL:self.GOAL + self.GOAL_SIZE], "little", signed=self.protocol == 2)

    def speed_limit_ticks_s(self) -> float:
        units = self.u16(self.SPEED_LIMIT) & 0x3FF
        return units * self.speed_unit_rpm / 60.0 * 4096 if units else math.inf

    def angle_limits(self) -> tuple[int, int]:
        """(lowest, highest) goal position the servo accepts: P1 CW/CCW Angle Limit, P2 Min/Max Position Limit."""
        if self.protocol == 1:
            return self.u16(6), self.u16(8)
        return int.from_bytes(self.table[52:56], "little"), int.from_bytes(self.table[48:52], "little")

    def joint_mode(self) -> bool:
        """P1 CW = CCW = 0 is wheel mode and both 4095 multi-turn: no position limits then."""
        return self.protocol == 2 or self.angle_limits() not in ((0, 0), (4095, 4095))

    def _goal_in(self, address: int, data: bytes) -> int | None:
        k = self.GOAL - address
        if k >= 0 and k + self.GOAL_SIZE <= len(data):
            return int.from_bytes(data[k:k + self.GOAL_SIZE], "little", signed=self.protocol == 2)
        return None

    def write(self, address: int, data: bytes) -> bool:
        goal = self._goal_in(address, data)
        if goal is not None:
            self.goal_log.append(goal)
            self.angle_limit_error = False
        ok = super().write(address, data)
        if ok and self.protocol == 1 and goal is not None:
            self.table[self.TORQUE] = 1  # an MX (P1) switches torque on when it gets a goal position
        return ok

    def refuses(self, address: int, data: bytes) -> int:
        if self.protocol == 2 and address < 64 and self.torque:
            return 7  # access error: EEPROM is written only with torque off
        goal = self._goal_in(address, data)
        if goal is None:
            return 0
        lo, hi = self.angle_limits()
        if self.joint_mode() and not lo <= goal <= hi:
            self.goal_log.append(goal)  # it was on the wire all the same
            self.refused_goals += 1
            self.angle_limit_error = True
            return 0x02 if self.protocol == 1 else 6  # P1 angle limit error bit, P2 data limit error
        return 0

    def alarm(self) -> int:
        return 0x02 if self.protocol == 1 and self.angle_limit_error else 0

    def tick(self, now: float) -> None:
        dt = max(now - self._last, 0.0)
        self._last = now
        if self.torque and dt > 0.0:
            step = (self.goal() - self.position) * (1.0 - math.exp(-dt / self.tau))
            limit = self.speed_limit_ticks_s() * dt
            step = max(-limit, min(limit, step))
            self.position += step
            self.velocity = step / dt
        elif not self.torque:
            self.velocity = 0.0
        self._write_present()
        super().tick(now)

    def _write_present(self) -> None:
        pos = min(max(round(self.position), 0), 4095)
        speed = min(round(abs(self.velocity) * 60.0 / 4096 / self.speed_unit_rpm), 1023)
        load = min(round(abs(self.goal() - self.position) * 2), 1023) if self.torque else 0
        self.put(self.POS, pos, 2)
        self.put(self.SPEED, speed | (0x400 if self.velocity < 0 else 0), 2)
        self.put(self.LOAD, load | (0x400 if self.goal() < self.position else 0), 2)
        self.table[self.VOLT] = self.voltage_dv
        self.table[self.TEMP] = self.temperature


class MX2Servo(MXServo):
    """MX(2.0)/X-series servo with the Protocol 2.0 control table."""

    protocol = 2
    TORQUE, GOAL, SPEED_LIMIT, POS, SPEED, LOAD, VOLT, TEMP = 64, 116, 112, 132, 128, 126, 144, 146
    GOAL_SIZE = 4
    speed_unit_rpm = 0.229

    def _init_table(self, start_ticks: int) -> None:
        self.put(0, self.model_number, 2)
        self.table[6], self.table[7], self.table[8], self.table[11], self.table[13] = 0x2B, self.id, 3, 3, 2
        self.put(48, 4095, 4)
        self.table[68] = 2
        self.put(self.GOAL, start_ticks, 4)
        self.tick(time.monotonic())

    def speed_limit_ticks_s(self) -> float:
        units = int.from_bytes(self.table[112:116], "little")
        return units * self.speed_unit_rpm / 60.0 * 4096 if units else math.inf

    def _write_present(self) -> None:
        self.put(self.POS, round(self.position), 4)
        self.put(self.SPEED, round(self.velocity * 60.0 / 4096 / self.speed_unit_rpm), 4)
        load = round((self.goal() - self.position) * 2) if self.torque else 0
        self.put(self.LOAD, max(-1000, min(1000, load)), 2)
        self.put(self.VOLT, self.voltage_dv, 2)
        self.table[self.TEMP] = self.temperature


class ServoBusEmulator:
    """The bus: a thread that parses instruction packets from the pty and answers for every device on it."""

    def __init__(self, protocol: int = 1, ids: Iterable[int] = range(1, 21), cm730: bool | None = None,
                 baudrate: int = 1_000_000, timing: bool = True, model_number: int | None = None,
                 chain: bool = True, tau: float = 0.03) -> None:
        if protocol not in (1, 2):
            raise ValueError("protocol must be 1 or 2")
        self.protocol = protocol
        self.baudrate = baudrate
        self.timing = timing
        self.chain = chain  # P1 BULK_READ/P2 SYNC_READ: a device waits for its predecessor's status packet
        cls = MXServo if protocol == 1 else MX2Servo
        number = model_number if model_number is not None else (310 if protocol == 1 else 311)
        self.devices: dict[int, Device] = {i: cls(i, number, tau) for i in ids}
        self.cm730: CM730Device | None = None
        if cm730 if cm730 is not None else protocol == 1:
            if protocol != 1:
                raise ValueError("the CM-730 speaks Protocol 1.0 only")
            self.cm730 = CM730Device()
            self.devices[CM730_ID] = self.cm730
        self.stats: dict[str, int] = {"instructions": 0, "bad_instructions": 0, "status_packets": 0,
                                      "corrupted": 0, "bulk_reads": 0, "sync_reads": 0, "sync_writes": 0}
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.port = os.ttyname(self._slave)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="servo-bus-emulator", daemon=True)
        self._bus_free = 0.0
        self._noise = b""

    # ---------------------------------------------------------------- control

    def start(self) -> ServoBusEmulator:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)
        for fd in (self._master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)

    def __enter__(self) -> ServoBusEmulator:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def servo(self, dxl_id: int) -> MXServo:
        dev = self.devices[dxl_id]
        assert isinstance(dev, MXServo)
        return dev

    def silence(self, dxl_id: int, silent: bool = True) -> None:
        with self._lock:
            self.devices[dxl_id].silent = silent

    def corrupt(self, dxl_id: int, kind: str, count: int = 1) -> None:
        """Garble the next `count` status packets of one device."""
        if kind not in CORRUPTIONS:
            raise ValueError(f"unknown corruption {kind!r}; one of {CORRUPTIONS}")
        with self._lock:
            self.devices[dxl_id].corruptions.extend([kind] * count)

    def inject(self, noise: bytes) -> None:
        """Put these bytes on the wire just before the next status packet (line noise, a babbling device)."""
        with self._lock:
            self._noise += noise

    def pending_corruptions(self) -> int:
        with self._lock:
            return sum(len(d.corruptions) for d in self.devices.values())

    # ---------------------------------------------------------------- the wire

    def _run(self) -> None:
        buf = bytearray()
        while not self._stop.is_set():
            try:
                ready, _, _ = select.select([self._master], [], [], 0.05)
            except (OSError, ValueError):
                return
            if not ready:
                if buf:
                    del buf[0]  # a half packet that never completed: resynchronise
                    self._parse(buf)
                continue
            try:
                chunk = os.read(self._master, 4096)
            except OSError:
                return
            buf += chunk
            self._parse(buf)

    def _parse(self, buf: bytearray) -> None:
        header = P1_HEADER if self.protocol == 1 else P2_HEADER
        while True:
            start = buf.find(header)
            if start < 0:
                del buf[:max(len(buf) - len(header) + 1, 0)]
                return
            del buf[:start]
            if self.protocol == 1:
                if len(buf) < 4:
                    return
                if buf[2] == 0xFF:  # FF FF FF: the real header starts one byte later
                    del buf[0]
                    continue
                total = buf[3] + 4
                if len(buf) < total:
                    return
                packet = bytes(buf[:total])
                del buf[:total]
                if p1_checksum(packet[2:-1]) != packet[-1]:
                    self.stats["bad_instructions"] += 1
                    continue
                self._handle_p1(packet[2], packet[4], packet[5:-1], len(packet))
            else:
                if len(buf) < 7:
                    return
                total = 7 + (buf[5] | buf[6] << 8)
                if len(buf) < total:
                    return
                packet = bytes(buf[:total])
                del buf[:total]
                if crc16(packet[:-2]) != int.from_bytes(packet[-2:], "little"):
                    self.stats["bad_instructions"] += 1
                    continue
                body = unstuff(packet[7:-2])
                self._handle_p2(packet[4], body[0], body[1:], len(packet))

    def _answers(self, dev: Device | None) -> bool:
        if dev is None or dev.silent:
            return False
        # servos are unpowered until the CM-730's Dynamixel power is switched on
        return self.cm730 is None or dev is self.cm730 or self.cm730.power

    def _send(self, replies: list[tuple[Device, bytes]], instruction_len: int) -> None:
        """Write status packets at the times the wire would deliver them."""
        byte_s = 10.0 / self.baudrate
        now = time.perf_counter()
        t = max(now, self._bus_free) + instruction_len * byte_s
        for dev, packet in replies:
            packet = self._maybe_corrupt(dev, packet)
            if self._noise:
                with self._lock:
                    packet, self._noise = self._noise + packet, b""
            t += len(packet) * byte_s
            if self.timing:
                delay = t - time.perf_counter()
                if delay > 0:
                    time.sleep(delay)
            os.write(self._master, packet)
            self.stats["status_packets"] += 1
        self._bus_free = t if self.timing else 0.0

    def _maybe_corrupt(self, dev: Device, packet: bytes) -> bytes:
        with self._lock:
            if not dev.corruptions:
                return packet
            kind = dev.corruptions.pop(0)
        self.stats["corrupted"] += 1
        b = bytearray(packet)
        len_at = 3 if self.protocol == 1 else 5
        if kind == "checksum":
            b[-1] ^= 0x5A
        elif kind == "length_long":
            b[len_at] = (b[len_at] + 3) & 0xFF
        elif kind == "length_short":
            b[len_at] = max(b[len_at] - 1, 2)
        elif kind == "truncate":
            b = b[:len(b) // 2]
        elif kind == "short_data":  # well-formed but one data byte too few
            if self.protocol == 1:
                return p1_packet(dev.id, packet[4], packet[5:-2])
            return p2_packet(dev.id, unstuff(packet[7:-2])[:-1])
        return bytes(b)

    def _tick(self, ids: Iterable[int]) -> None:
        now = time.monotonic()
        for i in ids:
            dev = self.devices.get(i)
            if dev is not None:
                dev.tick(now)

    # ---------------------------------------------------------------- Protocol 1.0

    def _status1(self, dev: Device, params: bytes = b"", error: int = 0) -> bytes:
        return p1_packet(dev.id, error | dev.error | dev.alarm(), params)

    def _handle_p1(self, dxl_id: int, inst: int, params: bytes, n: int) -> None:
        self.stats["instructions"] += 1
        dev = self.devices.get(dxl_id)
        replies: list[tuple[Device, bytes]] = []
        if inst == 0x01:  # PING
            if dev is not None and self._answers(dev):
                replies.append((dev, self._status1(dev)))
        elif inst == 0x02 and len(params) == 2:  # READ
            if dev is not None and self._answers(dev):
                dev.tick(time.monotonic())
                data = dev.read(params[0], params[1])
                replies.append((dev, self._status1(dev, data) if data is not None else self._status1(dev, error=0x08)))
        elif inst == 0x03 and len(params) >= 2:  # WRITE
            targets = list(self.devices.values()) if dxl_id == BROADCAST else [dev] if dev else []
            for target in targets:
                if self._answers(target):
                    target.tick(time.monotonic())
                    refused = target.refuses(params[0], params[1:])
                    ok = not refused and target.write(params[0], params[1:])
                    if dxl_id != BROADCAST:
                        replies.append((target, self._status1(target, error=refused or (0 if ok else 0x08))))
        elif inst == 0x83 and dxl_id == BROADCAST and len(params) >= 2:  # SYNC_WRITE
            self.stats["sync_writes"] += 1
            address, size = params[0], params[1]
            now = time.monotonic()
            for k in range(2, len(params) - size, size + 1):
                peer = self.devices.get(params[k])
                if peer is not None and self._answers(peer):
                    peer.tick(now)
                    data = params[k + 1:k + 1 + size]
                    if not peer.refuses(address, data):
                        peer.write(address, data)
        elif inst == 0x92 and dxl_id == BROADCAST and len(params) >= 1:  # BULK_READ
            self.stats["bulk_reads"] += 1
            now = time.monotonic()
            for k in range(1, len(params) - 2, 3):
                length, target_id, address = params[k], params[k + 1], params[k + 2]
                member = self.devices.get(target_id)
                if member is None or not self._answers(member):
                    if self.chain:
                        break  # the next device waits for this one's status packet forever
                    continue
                member.tick(now)
                data = member.read(address, length)
                replies.append((member, self._status1(member, data or b"", 0 if data is not None else 0x08)))
        elif dev is not None and self._answers(dev):
            replies.append((dev, self._status1(dev, error=0x40)))
        self._send(replies, n)

    # ---------------------------------------------------------------- Protocol 2.0

    def _status2(self, dev: Device, params: bytes = b"", error: int = 0) -> bytes:
        return p2_packet(dev.id, bytes([0x55, error | dev.error]) + params)

    def _handle_p2(self, dxl_id: int, inst: int, params: bytes, n: int) -> None:
        self.stats["instructions"] += 1
        dev = self.devices.get(dxl_id)
        replies: list[tuple[Device, bytes]] = []
        now = time.monotonic()
        if inst == 0x01:  # PING
            targets = list(self.devices.values()) if dxl_id == BROADCAST else [dev] if dev else []
            for target in targets:
                if self._answers(target):
                    replies.append((target, self._status2(target, target.model_number.to_bytes(2, "little")
                                                          + bytes([target.table[6]]))))
        elif inst == 0x02 and len(params) == 4:  # READ
            if dev is not None and self._answers(dev):
                dev.tick(now)
                data = dev.read(params[0] | params[1] << 8, params[2] | params[3] << 8)
                replies.append((dev, self._status2(dev, data) if data is not None else self._status2(dev, error=7)))
        elif inst == 0x03 and len(params) >= 3:  # WRITE
            targets = list(self.devices.values()) if dxl_id == BROADCAST else [dev] if dev else []
            for target in targets:
                if self._answers(target):
                    target.tick(now)
                    address = params[0] | params[1] << 8
                    refused = target.refuses(address, params[2:])
                    ok = not refused and target.write(address, params[2:])
                    if dxl_id != BROADCAST:
                        replies.append((target, self._status2(target, error=refused or (0 if ok else 7))))
        elif inst == 0x82 and len(params) >= 4:  # SYNC_READ
            self.stats["sync_reads"] += 1
            address, length = params[0] | params[1] << 8, params[2] | params[3] << 8
            for target_id in params[4:]:
                member = self.devices.get(target_id)
                if member is None or not self._answers(member):
                    if self.chain:
                        break
                    continue
                member.tick(now)
                data = member.read(address, length)
                replies.append((member, self._status2(member, data or b"", 0 if data is not None else 7)))
        elif inst == 0x92:  # BULK_READ
            self.stats["bulk_reads"] += 1
            for k in range(0, len(params) - 4, 5):
                member = self.devices.get(params[k])
                if member is None or not self._answers(member):
                    if self.chain:
                        break
                    continue
                member.tick(now)
                data = member.read(params[k + 1] | params[k + 2] << 8, params[k + 3] | params[k + 4] << 8)
                replies.append((member, self._status2(member, data or b"", 0 if data is not None else 7)))
        elif inst == 0x83 and len(params) >= 4:  # SYNC_WRITE
            self.stats["sync_writes"] += 1
            address, size = params[0] | params[1] << 8, params[2] | params[3] << 8
            for k in range(4, len(params) - size, size + 1):
                peer = self.devices.get(params[k])
                if peer is not None and self._answers(peer):
                    peer.tick(now)
                    data = params[k + 1:k + 1 + size]
                    if not peer.refuses(address, data):
                        peer.write(address, data)
        elif dev is not None and self._answers(dev):
            replies.append((dev, self._status2(dev, error=2)))
        self._send(replies, n)
