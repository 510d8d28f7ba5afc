"""pes_ref.core.progress: the one progress type, its clock of the time left, and the one
line every command prints (the hot loops' per-step hook is tested in test_budget.py)."""
import math

import pytest

from pes_ref.core.progress import Clock, Progress, clock_time, progress_line


@pytest.mark.parametrize("seconds, text", [(0, "0:00"), (4.4, "0:04"), (59.6, "1:00"), (61, "1:01"),
                                           (3600, "60:00"), (-3, "0:00"), (math.inf, "?"), (math.nan, "?")])
def test_clock_time(seconds, text):
    assert clock_time(seconds) == text


def test_a_line_shows_stage_count_figures_rate_elapsed_and_time_left():
    p = Progress("design funnel", "stage 1/2", 30, 300, "it", 5.21, 6.2, 70.0,
                 (("grid", (25, 25)), ("steps", 200), ("loss", 0.123456), ("in_band", 0.4)))
    assert progress_line(p) == ("design funnel: stage 1/2 | it 30/300 | grid 25x25 | steps 200 | loss 0.1235 | "
                                "in_band 0.4 | 5.21 it/s | elapsed 0:06 | left 1:10")
    assert p.figure("loss") == 0.123456 and p.figure("fitness") is None


def test_a_line_without_stage_or_figures_and_a_fast_rate():
    p = Progress("c.npz", "", 1200, 3000, "steps", 2512.7, 1.4, math.inf)
    assert progress_line(p) == "c.npz | steps 1200/3000 | 2513 steps/s | elapsed 0:01 | left ?"


def test_the_clock_times_each_segment_by_its_own_rate():
    clock = Clock([(0, 4, 10), (4, 8, 40)])            # a second segment 4x as costly per unit
    assert clock.seconds_left(0) == math.inf            # nothing timed yet
    for k in range(2):
        clock.tick(k, 0.010)
    assert clock.rate(0) == pytest.approx(100.0)
    # two more of the first segment at its rate, four of the second scaled by the cost
    assert clock.seconds_left(2) == pytest.approx(2 * 0.010 + 4 * 0.040)
    for k in range(4, 6):
        clock.tick(k, 0.050)                            # slower than the scaled estimate
    assert clock.rate(1) == pytest.approx(20.0)
    assert clock.seconds_left(6) == pytest.approx(2 * 0.050)
    assert clock.seconds_left(8) == 0.0 and clock.seconds_left(3, total=4) == pytest.approx(0.010)


def test_several_units_in_one_tick():
    clock = Clock([(0, 100)])
    clock.tick(0, 2.0, units=10)
    assert clock.rate(0) == pytest.approx(5.0) and clock.seconds_left(10) == pytest.approx(18.0)
    clock.tick(10, 1.0, units=0)                        # time without a unit done slows the rate
    assert clock.rate(0) == pytest.approx(10 / 3)
