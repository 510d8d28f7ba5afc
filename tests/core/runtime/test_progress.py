"""pes_ref.core.runtime.progress: the one progress type, its clock of the time left, the one
line every command prints and how it is shown (the hot loops' per-step hook is tested in
test_budget.py)."""
import io
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from pes_ref.core.runtime.progress import Clock, Progress, ProgressWriter, clock_time, is_progress_line, progress_line


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


def test_a_line_before_anything_is_timed_says_so():
    p = Progress("design funnel", "stage 1/1", 1, 6, "it", 0.0, 19.0, math.inf)
    assert progress_line(p) == "design funnel: stage 1/1 | it 1/6 | ? it/s | elapsed 0:19 | left ?"


def test_the_clock_times_each_segment_by_its_own_rate():
    clock = Clock([(0, 4, 10), (4, 8, 40)], warmup=0)  # a second segment 4x as costly per unit
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
    clock = Clock([(0, 100)], warmup=0)
    clock.tick(0, 2.0, units=10)
    assert clock.rate(0) == pytest.approx(5.0) and clock.seconds_left(10) == pytest.approx(18.0)
    clock.tick(10, 1.0, units=0)                        # time without a unit done slows the rate
    assert clock.rate(0) == pytest.approx(10 / 3)


def test_the_first_tick_of_each_segment_is_its_warm_up():
    """The first iteration of a stage carries one-off costs (compiling, imports): at
    iteration 1 of a run whose later iterations take 0.1 s the time left is unknown, not
    the minutes the first iteration's 19 s would make of it."""
    clock = Clock([(0, 10), (10, 20, 2)])
    clock.tick(0, 0.5, units=0)                         # time before the first unit: warm-up too
    clock.tick(0, 19.0)                                 # iteration 1, compiling
    assert clock.rate(0) == 0.0 and clock.seconds_left(1) == math.inf
    clock.tick(1, 0.1)
    assert clock.rate(0) == pytest.approx(10.0)
    assert clock.seconds_left(2) == pytest.approx(8 * 0.1 + 10 * 2 * 0.1)
    clock.tick(10, 5.0)                                 # the second segment's warm-up: scaled from the first
    assert clock.rate(1) == 0.0 and clock.seconds_left(11) == pytest.approx(9 * 0.2)
    clock.tick(11, 0.3)
    assert clock.rate(1) == pytest.approx(1 / 0.3) and clock.seconds_left(12) == pytest.approx(8 * 0.3)


class _Terminal(io.StringIO):
    """A stream that says it is a terminal."""

    def isatty(self):
        return True


def _lines(n):
    return [Progress("design funnel", "stage 1/2", k, 9, "it", 10.0, k, 9 - k) for k in range(1, n + 1)]


def test_at_a_terminal_the_line_is_rewritten_in_place(monkeypatch):
    monkeypatch.setenv("TERM", "xterm")
    monkeypatch.setenv("COLUMNS", "200")
    out = _Terminal()
    w = ProgressWriter(out)
    one, two, three = _lines(3)
    w.show(one)
    w.show(two)
    w.note("design funnel: now stage 2/2")
    w.show(three)
    w.end()
    w.end()                                             # a second end writes nothing
    assert out.getvalue() == (f"\r\x1b[K{progress_line(one)}\r\x1b[K{progress_line(two)}\n"
                              f"design funnel: now stage 2/2\n\r\x1b[K{progress_line(three)}\n")


def test_a_line_wider_than_the_terminal_is_cleared_over_all_its_rows(monkeypatch):
    monkeypatch.setenv("TERM", "xterm")
    monkeypatch.setenv("COLUMNS", "30")
    out = _Terminal()
    w = ProgressWriter(out)
    one, two = _lines(2)
    rows = math.ceil(len(progress_line(one)) / 30)
    assert rows >= 3
    w.show(one)
    w.show(two)
    assert out.getvalue() == f"\r\x1b[K{progress_line(one)}\r\x1b[{rows - 1}A\x1b[J{progress_line(two)}"


@pytest.mark.parametrize("stream, term", [(io.StringIO(), "xterm"), (_Terminal(), "dumb")], ids=["pipe", "dumb"])
def test_elsewhere_each_is_a_plain_line(stream, term, monkeypatch):
    monkeypatch.setenv("TERM", term)
    w = ProgressWriter(stream)
    one, two = _lines(2)
    w.show(one)
    w.note("a note")
    w.show(two)
    w.end()
    assert stream.getvalue() == f"{progress_line(one)}\na note\n{progress_line(two)}\n"


_TEXT = st.text(st.characters(blacklist_categories=("Cs", "Cc"), blacklist_characters="|"), min_size=1, max_size=12)
_FIGURE = st.one_of(st.floats(allow_nan=False), st.integers(-10 ** 6, 10 ** 6), st.tuples(st.integers(1, 999), st.integers(1, 999)),
                    _TEXT)


@given(label=_TEXT.filter(lambda t: t.strip() == t and not t.startswith(("error: ", "warning: "))), stage=st.sampled_from(["", "stage 1/2", "forward", "estimate"]),
       done=st.integers(0, 10 ** 6), total=st.integers(0, 10 ** 6), unit=st.sampled_from(["it", "steps", "percent"]),
       rate=st.floats(0, 1e6), elapsed=st.floats(0, 1e5), left=st.one_of(st.floats(0, 1e5), st.just(math.inf)),
       figures=st.lists(st.tuples(st.sampled_from(["loss", "grid", "N", "GiB"]), _FIGURE), max_size=3))
def test_every_progress_line_is_recognized(label, stage, done, total, unit, rate, elapsed, left, figures):
    """What a test leaves out of a command's stderr (tests/_helpers.without_progress) is every
    line progress_line makes, whatever its figures."""
    line = progress_line(Progress(label, stage, done, total, unit, rate, elapsed, left, tuple(figures)))
    assert is_progress_line(line), line


@pytest.mark.parametrize("line", [
    "error: --start 0.45,0 is inside blocked space: the parts' interiors overlap there",
    "warning: dev.toml: [energy] r_c = 0.1 is wider than the clearance | elapsed 0:03 | left 0:01",
    "error: dev.toml: distance | percent 100/100 | 33 percent/s | elapsed 0:03 | left 0:00 (then refused)",
    "error: dev.toml: distance | percent 100/100 | 33 percent/s | elapsed 0:03 | left 0:00",
    "warning: cam.toml: drive | percent 40/100 | ? percent/s | elapsed 0:06 | left ?",
    "wrote law.csv (motion law)",
    "interrupted",
    "",
])
def test_a_command_s_own_lines_are_not_progress_lines(line):
    assert not is_progress_line(line)


def test_progress_lines_start_after_a_few_seconds_and_come_every_period(capsys):
    from pes_ref.core.runtime.progress import LONG_RUN, PERIOD, ShareLines, is_progress_line
    now = [0.0]
    lines_of = ShareLines("cam.toml", clock=lambda: now[0])
    for t, done in ((1.0, 1), (LONG_RUN + 0.1, 2), (LONG_RUN + 0.2, 3), (LONG_RUN + PERIOD + 0.2, 4)):
        now[0] = t
        lines_of("drive", done, 8)
    lines = capsys.readouterr().err.splitlines()
    assert all(is_progress_line(line) for line in lines), lines
    assert [line.split(" | ")[:2] + line.split(" | ")[-2:] for line in lines] == [
        ["cam.toml: drive", "percent 25/100", "elapsed 0:03", "left 0:06"],     # 2.1 s for the first quarter
        ["cam.toml: drive", "percent 50/100", "elapsed 0:05", "left 0:04"]]
