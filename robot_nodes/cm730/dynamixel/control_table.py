"""Control-table addresses of MX (Protocol 1.0), MX(2.0)/X (Protocol 2.0) servos and the CM-730 sub-controller."""

from __future__ import annotations

CM730_ID = 200
CM730_MODEL_NUMBER = 0x7300


class P1:
    """MX-28/64/106 with Protocol 1.0 firmware (and AX-12 for the shared part)."""

    MODEL_NUMBER = 0
    ID = 3
    RETURN_DELAY = 5
    CW_ANGLE_LIMIT = 6  # EEPROM, 2 bytes: lowest goal position the servo accepts
    CCW_ANGLE_LIMIT = 8  # EEPROM, 2 bytes: highest; CW = CCW = 0 is wheel mode, both 4095 multi-turn
    TORQUE_ENABLE = 24
    GOAL_POSITION = 30
    MOVING_SPEED = 32
    TORQUE_LIMIT = 34
    PRESENT_POSITION = 36
    PRESENT_SPEED = 38
    PRESENT_LOAD = 40
    PRESENT_VOLTAGE = 42
    PRESENT_TEMPERATURE = 43
    # block reads: position/speed/load every cycle, + voltage/temperature on slow cycles
    FAST_BLOCK = (36, 6)
    SLOW_BLOCK = (36, 8)


class P2:
    """MX(2.0) firmware and the X series with Protocol 2.0."""

    MODEL_NUMBER = 0
    ID = 7
    OPERATING_MODE = 11
    MAX_POSITION_LIMIT = 48  # EEPROM, 4 bytes, used in position control mode (3) only
    MIN_POSITION_LIMIT = 52  # EEPROM, 4 bytes
    EEPROM_END = 64  # addresses below are EEPROM: written only with torque off
    TORQUE_ENABLE = 64
    HARDWARE_ERROR = 70
    GOAL_CURRENT = 102
    PROFILE_VELOCITY = 112
    GOAL_POSITION = 116
    PRESENT_LOAD = 126
    PRESENT_VELOCITY = 128
    PRESENT_POSITION = 132
    PRESENT_VOLTAGE = 144
    PRESENT_TEMPERATURE = 146
    # load(2) velocity(4) position(4); the slow block runs on to the temperature byte
    FAST_BLOCK = (126, 10)
    SLOW_BLOCK = (126, 21)


class CM730:
    """CM-730 sub-controller table (Darwin-OP framework CM730.h)."""

    DYNAMIXEL_POWER = 24
    LED_PANEL = 25
    LED_HEAD = 26
    LED_EYE = 28
    BUTTONS = 30
    GYRO_Z = 38
    GYRO_Y = 40
    GYRO_X = 42
    ACCEL_X = 44
    ACCEL_Y = 46
    ACCEL_Z = 48
    VOLTAGE = 50
    # the block the Darwin framework reads every cycle: power, LEDs, buttons, IMU, voltage
    BLOCK = (24, 30)
    BUTTON_MODE = 0x01
    BUTTON_START = 0x02
