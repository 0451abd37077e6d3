"""A timer says what it takes: a rate in Hz or a period in seconds, by name (rclpy's create_timer takes a period)."""

from __future__ import annotations

import pytest

from robot_nodes.runtime.loop import EventLoop, Timer, timer_period_s


def test_a_rate_and_a_period_give_the_same_timer() -> None:
    assert timer_period_s(50.0, None) == pytest.approx(0.02)
    assert timer_period_s(None, 0.02) == pytest.approx(0.02)


@pytest.mark.parametrize(("rate_hz", "period_s"), [(None, None), (10.0, 0.1), (0.0, None), (None, 0.0),
                                                   (-5.0, None), (None, float("inf")), (float("nan"), None)])
def test_a_timer_without_exactly_one_sound_unit_is_refused(rate_hz: float | None, period_s: float | None) -> None:
    with pytest.raises(ValueError, match=r"rate_hz|period"):
        timer_period_s(rate_hz, period_s)


def test_set_rate_and_set_period_change_the_period() -> None:
    timer = Timer(EventLoop(lambda callback, exc: None), 0.1, lambda: None, "t")
    timer.set_rate(rate_hz=200.0)
    assert timer.period_s == pytest.approx(0.005)
    timer.set_period(period_s=2.0)
    assert timer.period_s == 2.0
    with pytest.raises(ValueError):
        timer.set_rate(rate_hz=0.0)
