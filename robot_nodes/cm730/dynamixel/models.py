"""Servo models and their unit conversions: encoder ticks, speed units, load/current to torque."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class ServoModel:
    """What differs between servo types: resolution, units, protocol, torque scale."""

    name: str
    protocol: int
    model_number: int
    ticks_per_rev: float  # encoder ticks over a full turn (AX: 1024 ticks over 300 deg -> 1228.8)
    centre: int  # ticks at 0 rad
    max_tick: int
    speed_unit_rpm: float  # present speed / velocity unit
    stall_torque_nm: float  # at 12 V; turns load fractions into (approximate) Nm
    current_unit_a: float = 0.0  # > 0: P2 present-load register is a current in this unit
    stall_current_a: float = 0.0

    @property
    def rad_per_tick(self) -> float:
        return 2.0 * math.pi / self.ticks_per_rev


_RPM_TO_RAD_S = 2.0 * math.pi / 60.0

MODELS: dict[str, ServoModel] = {m.name: m for m in (
    ServoModel("AX-12", 1, 12, 1024 * 360 / 300, 512, 1023, 0.111, 1.5),
    ServoModel("MX-28", 1, 29, 4096, 2048, 4095, 0.114, 2.5),
    ServoModel("MX-64", 1, 310, 4096, 2048, 4095, 0.114, 6.0),
    ServoModel("MX-106", 1, 320, 4096, 2048, 4095, 0.114, 8.4),
    ServoModel("MX-28(2.0)", 2, 30, 4096, 2048, 4095, 0.229, 2.5),  # present load in 0.1 %
    ServoModel("MX-64(2.0)", 2, 311, 4096, 2048, 4095, 0.229, 6.0, 0.00336, 4.1),
    ServoModel("MX-106(2.0)", 2, 321, 4096, 2048, 4095, 0.229, 8.4, 0.00336, 5.2),
    ServoModel("XH430-W350", 2, 1000, 4096, 2048, 4095, 0.229, 3.4, 0.00269, 1.3),
    ServoModel("XH430-W210", 2, 1010, 4096, 2048, 4095, 0.229, 2.5, 0.00269, 1.3),
    ServoModel("XM430-W350", 2, 1020, 4096, 2048, 4095, 0.229, 4.1, 0.00269, 2.3),
    ServoModel("XH540-W270", 2, 1100, 4096, 2048, 4095, 0.229, 10.6, 0.00269, 4.4),
    ServoModel("XH540-W150", 2, 1110, 4096, 2048, 4095, 0.229, 7.3, 0.00269, 4.4),
)}


class UnknownServoModel(ValueError):
    """A configuration names a servo model this backend has no table for."""


def model(name: str) -> ServoModel:
    try:
        return MODELS[name]
    except KeyError:
        raise UnknownServoModel(f"unknown servo model {name!r}; known: {', '.join(sorted(MODELS))}") from None


def model_by_number(protocol: int, number: int) -> ServoModel | None:
    for m in MODELS.values():
        if m.protocol == protocol and m.model_number == number:
            return m
    return None


def ticks_to_servo_rad(m: ServoModel, ticks: int) -> float:
    return (ticks - m.centre) * m.rad_per_tick


def servo_rad_to_ticks(m: ServoModel, rad: float) -> int:
    """Nearest encoder tick, clamped to the servo's position range (never wraps around)."""
    if not math.isfinite(rad):
        raise ValueError(f"position {rad!r} is not a finite number")
    t = round(m.centre + rad / m.rad_per_tick)
    return min(max(t, 0), m.max_tick)


def p1_signed_magnitude(raw: int) -> int:
    """P1 present speed/load: bits 0-9 magnitude, bit 10 set = clockwise (negative)."""
    mag = raw & 0x3FF
    return -mag if raw & 0x400 else mag


def p1_speed_to_rad_s(m: ServoModel, raw: int) -> float:
    return p1_signed_magnitude(raw) * m.speed_unit_rpm * _RPM_TO_RAD_S


def p1_load_to_nm(m: ServoModel, raw: int) -> float:
    """Load is a fraction of max torque (1023 = 100 %); scaled by the stall torque it is a rough Nm."""
    return p1_signed_magnitude(raw) / 1023.0 * m.stall_torque_nm


def rad_s_to_p1_moving_speed(m: ServoModel, rad_s: float) -> int:
    """P1 moving speed 1..1023; 0 (also for 0/non-finite input) means 'as fast as possible' on MX servos."""
    if not math.isfinite(rad_s) or rad_s == 0.0:
        return 0
    units = round(abs(rad_s) / _RPM_TO_RAD_S / m.speed_unit_rpm)
    return min(max(units, 1), 1023)


def signed(value: int, bits: int) -> int:
    sign = 1 << (bits - 1)
    return (value & (sign - 1)) - (value & sign)


def p2_velocity_to_rad_s(m: ServoModel, raw: int) -> float:
    return signed(raw, 32) * m.speed_unit_rpm * _RPM_TO_RAD_S


def p2_load_to_nm(m: ServoModel, raw: int) -> float:
    value = signed(raw, 16)
    if m.current_unit_a > 0.0:
        return value * m.current_unit_a / m.stall_current_a * m.stall_torque_nm
    return value / 1000.0 * m.stall_torque_nm  # MX-28(2.0): load in 0.1 %


def rad_s_to_p2_profile_velocity(m: ServoModel, rad_s: float) -> int:
    """Profile velocity in 0.229 rpm; 0 means unlimited."""
    if not math.isfinite(rad_s) or rad_s == 0.0:
        return 0
    return max(1, min(round(abs(rad_s) / _RPM_TO_RAD_S / m.speed_unit_rpm), 32767))
