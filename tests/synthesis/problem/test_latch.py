"""The latch's problem file and its no-premature-release checks, at a small size.

The checks are scenarios of ``[evaluate]``: a hold twice as long, and a load with no fire push.
Here they are shown to run under their own schedules (the trigger comes later, or never) and to
catch a release: on the flat surface the dart's spring pulls every particle out before any
trigger, and both checks fail it. The full-size design passes them (``make problems-study``,
Fig. 13, docs/problems.md "The latch")."""
import numpy as np
import pytest

from pes_ref import synthesis
from pes_ref.synthesis import load_problem, shipped_problem, with_sets


@pytest.fixture(scope="module")
def latch():
    return with_sets(load_problem(shipped_problem("latch")), {"surface.shape": [12, 12], "evaluate.particles": 16})


def test_the_schedule_has_three_phases(latch):
    assert latch.phases() == [(0.0, 1.5, "load"), (1.5, 4.0, ""), (4.0, 5.0, "fire"), (5.0, 6.0, "")]
    assert [name for name, _ in latch.tests] == ["load", "hold", "fire"]
    long_hold, no_fire = latch.scenarios
    assert latch.phases(long_hold.forces, long_hold.n_steps) == [
        (0.0, 1.5, "load"), (1.5, 6.0, ""), (6.0, 7.0, "fire"), (7.0, 8.0, "")]
    assert latch.phases(no_fire.forces, no_fire.n_steps) == [(0.0, 1.5, "load"), (1.5, 8.0, "")]


def test_each_scenario_runs_under_its_own_schedule(latch):
    """The trigger (q1, held at -0.5 by its spring) moves when the schedule pulls it, and only then."""
    flat = latch.flat_values()
    q1 = {name: run.traj.x[:, :, 1] for name, run in (
        ("main", latch.run(flat, 5, 16)), *((s.name, latch.run(flat, 5, 16, s)) for s in latch.scenarios))}
    step = lambda t: int(round(t / latch.dt))  # noqa: E731
    assert q1["main"].shape[0] == step(6.0) + 1 and q1["no_fire"].shape[0] == step(8.0) + 1
    assert np.all(q1["main"][step(4.6)] > 0.0)                           # pulled during 4 <= t < 5
    assert np.all(np.abs(q1["long_hold"][:step(6.0)] + 0.5) < 0.2)       # not before 6 ...
    assert np.all(q1["long_hold"][step(6.6)] > 0.0)                      # ... then pulled
    assert np.all(np.abs(q1["no_fire"] + 0.5) < 0.2)                     # never
    np.testing.assert_array_equal(q1["no_fire"][:step(1.5)], q1["main"][:step(1.5)])   # the same particles


def test_the_checks_catch_a_release_without_the_trigger(latch):
    """On the flat surface the spring pulls the particles back out during the hold: the hold fails,
    and so do both checks. They reach the exit edge just after the trigger's time, but slowly: the
    fire test's speed tells them from a release."""
    figures = synthesis.evaluate(latch, latch.flat_values(), seed=12345)
    assert figures["success_hold"] == 0.0 and figures["success_fraction"] == 0.0
    assert figures["scenario_long_hold_success_fraction"] == 0.0
    assert figures["scenario_no_fire_success_fraction"] == 0.0
    run = latch.run(latch.flat_values(), 12345, 16)
    out = run.traj.x[:, :, 0] <= latch.lower[0]
    assert out.any(axis=0).all()                                         # every particle leaves ...
    step = np.argmax(out, axis=0)
    assert np.all(step * latch.dt >= 4.0)                                # ... after t = 4 ...
    assert np.all(np.abs(run.traj.v[step, np.arange(16), 0]) < 1.0)      # ... slower than a release
    assert figures["success_fire"] == 0.0
