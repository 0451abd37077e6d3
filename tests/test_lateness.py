"""Old data after a link cut is told from live data, whatever the robot's clock says (server.lateness, the hub)."""

from __future__ import annotations

import time

import schemas
from server.hub import Hub, HubMessage
from server.lateness import LATE_AFTER_S, REBASE_AFTER_S, ClockOffset

SKEW = 37.25  # the robot's clock runs this far ahead of the laptop's


def test_a_burst_after_a_cut_is_late_and_live_data_is_not() -> None:
    offset = ClockOffset()
    t = 1000.0
    for k in range(200):  # 20 s of 10 Hz data, 5-15 ms on the way
        assert offset.late_by(t + k * 0.1 + 0.005 + 0.01 * (k % 2), t + k * 0.1 - SKEW) < LATE_AFTER_S
    cut_start, restored = t + 20.0, t + 21.5
    burst = [offset.late_by(restored + i * 0.001, cut_start + i * 0.1 - SKEW) for i in range(15)]  # sent in the cut
    assert all(b > LATE_AFTER_S for b in burst[:10])
    assert offset.late_by(restored + 0.05, restored + 0.04 - SKEW) < LATE_AFTER_S  # the first fresh message


def test_a_robot_clock_set_later_is_measured_again_instead_of_hiding_live_data() -> None:
    offset = ClockOffset()
    for k in range(100):
        offset.late_by(k * 0.1, k * 0.1)
    step = 5.0  # NTP set the robot's clock back by 5 s: everything looks 5 s old
    results = [offset.late_by(10.0 + k * 0.1, 10.0 + k * 0.1 - step) for k in range(40)]
    assert results[0] > LATE_AFTER_S
    rebased = next(i for i, r in enumerate(results) if r < LATE_AFTER_S)
    assert rebased * 0.1 <= REBASE_AFTER_S + 0.2 and all(r < LATE_AFTER_S for r in results[rebased:])


def test_the_hub_records_late_messages_but_shows_only_live_ones() -> None:
    hub = Hub()
    browser = hub.subscribe("browser")
    browser.subscribe("*", "*")
    recorder = hub.subscribe("recorder", include_late=True)
    recorder.subscribe("*", "*")
    state = schemas.make("humanoid_league_msgs/msg/RobotControlState", state=2)
    now = time.time()
    for _ in range(20):
        hub.publish(HubMessage("r1", "robot_state", "humanoid_league_msgs/msg/RobotControlState", now, state, "live",
                               sent=now - 0.01))
    late = HubMessage("r1", "robot_state", "humanoid_league_msgs/msg/RobotControlState", now, state, "live",
                      sent=now - 3.0)
    hub.publish(late)
    shown = browser.drain(1000)
    recorded = recorder.drain(1000)
    assert late not in shown and late in recorded and len(recorded) == len(shown) + 1
    assert hub.latest[("r1", "robot_state")] is not late
    assert hub.robots["r1"].streams["robot_state"].late == 1
