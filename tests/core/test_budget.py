"""What a run costs before it runs (pes_ref.core.budget): a run that cannot fit in the
available memory is refused in one line naming n_steps, N and the size, before any large
allocation; oracle runs longer than a few seconds print an estimate and progress lines;
the hot loops report progress only every few hundred steps, through an optional callback."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from _helpers import without_progress

import pes_ref
import pes_ref as pr
from pes_ref.cli import EXIT_ERROR, EXIT_OK
from pes_ref.core import budget
from pes_ref.core.runtime import progress
from pes_ref.oracle import case as oracle

ROOT = Path(pes_ref.__file__).resolve().parent.parent
GIB = 2 ** 30


def run_cli(*args, timeout=120):
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "pes_ref", *map(str, args)], capture_output=True, text=True,
                          env=env, timeout=timeout)


def small_case(n_steps=6, n=2) -> dict:
    rng = np.random.default_rng(5)
    return dict(values=rng.normal(size=(5, 7)), lower=np.zeros(2), upper=np.array([1.0, 1.5]),
                periodic=np.array([False, False]), dt=np.float64(0.01), n_steps=np.int64(n_steps), mode="dynamic",
                mass=np.float64(1.0), damping=np.float64(0.1), x0=rng.uniform(0.2, 0.8, (n, 2)),
                v0=np.zeros((n, 2)), objective="funnel", target=np.float64(0.5), when="final")


def _scene(n_steps):
    surf = pr.Surface(np.zeros((4, 4)), (0, 0), (1, 1), (False, False))
    return pr.Scene(surf, dt=0.01, n_steps=n_steps)


# =========================================================================== memory

@pytest.mark.parametrize("kind, grid", [("funnel", dict(grid=400)), ("oscillator", dict(grid0=400, grid1=400,
                                                                                      dt=0.005))])
@pytest.mark.parametrize("optimizer", ["rmsprop", "adam"])
def test_the_grid_estimate_bounds_the_measured_peak(kind, grid, optimizer):
    """GRID_ARRAYS bounds what tracemalloc sees a design allocate per grid node, over a
    coarse-to-fine run (a stage change resamples the grid and resets the optimizer)."""
    import dataclasses
    import tracemalloc

    from pes_ref import synthesis
    plan = dataclasses.replace(synthesis.new_design(kind, **grid).plan, n_particles=2, iterations=5,
                               optimizer=optimizer, stages=((0, 200), (2, 0)))
    # the same run once on a small grid first: what a process allocates once (imports, compiled
    # kernels' dispatch) is not the design's, whichever test of the session runs first
    small = {key: 20 for key in grid if key.startswith("grid")}
    synthesis.run_design(synthesis.new_design(kind, plan=dataclasses.replace(plan, stages=((0, 10), (2, 0))),
                                              polish=None, n_steps=5, **{**grid, **small}))
    tracemalloc.start()
    try:
        state = synthesis.new_design(kind, plan=plan, polish=None, n_steps=5, **grid)
        synthesis.run_design(state)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert state.status == "done" and state.values.shape == (400, 400)
    assert peak <= budget.GRID_ARRAYS * state.values.nbytes, peak / state.values.nbytes


def test_a_backward_pass_leaves_no_reference_cycle():
    """The grid adjoint's tables are freed when a run returns, not whenever the cyclic
    collector next runs (a design kept dozens of grids alive between collections)."""
    import gc
    surf = pr.Surface(np.random.default_rng(0).uniform(0, 0.1, (30, 30)), (0, 0), (1, 1), (False, False))
    scene = pr.Scene(surf, dt=0.01, n_steps=20, damping=0.5)
    x0 = [[0.3, 0.4], [0.6, 0.5]]
    pr.value_and_grad(scene, x0, None, pr.Funnel(0.5))      # the process's one-time loading (the loops) first
    gc.collect()
    gc.disable()
    try:
        pr.value_and_grad(scene, x0, None, pr.Funnel(0.5))
        assert gc.collect() == 0
    finally:
        gc.enable()


def test_a_grid_that_cannot_fit_is_refused_before_it_is_made():
    from pes_ref import synthesis
    with pytest.raises(budget.RunTooLargeError, match="grid = 100000 makes a surface of 100000 x 100000 nodes") as info:
        synthesis.new_design("funnel", grid=100000)
    assert info.value.key == "grid"
    with pytest.raises(budget.RunTooLargeError, match="grid1 = 10000000 makes a surface of 32 x 10000000 nodes") as info:
        synthesis.new_design("oscillator", grid1=10 ** 7)
    assert info.value.key == "grid1"

def test_the_memory_formula():
    """bytes = arrays * (T+1) * N * 2 * 8, with the arrays each kind of run holds, and a small
    run's kept lookups."""
    assert budget.run_bytes(99, 5, "simulate") == budget.ARRAYS["simulate"] * 100 * 5 * 2 * 8 + 48 * 100 * 5
    big = budget.LOOKUP_STATES
    assert budget.run_bytes(big, 1, "case") == budget.ARRAYS["case"] * (big + 1) * 2 * 8
    assert budget.ARRAYS["simulate"] < budget.ARRAYS["value_and_grad"] < budget.ARRAYS["case"]


def test_available_memory_is_read():
    avail = budget.available_memory()
    assert avail is None or avail > 0


def test_the_idle_maps_count_as_available(monkeypatch):
    """A new run reuses the idle maps of pes_ref.core.runtime.pages or gives them back first."""
    from pes_ref.core.runtime import pages
    monkeypatch.setattr(budget, "_system_memory", lambda: 1000)
    pages.release()
    held = pages.empty((pages.THRESHOLD // 8,))
    assert budget.available_memory() == 1000           # held by an array: not available
    del held
    assert budget.available_memory() == 1000 + pages.THRESHOLD
    pages.release()
    assert budget.available_memory() == 1000
    monkeypatch.setattr(budget, "_system_memory", lambda: None)
    assert budget.available_memory() is None


@pytest.mark.parametrize("halved", [False, True], ids=["one-thread", "halves"])
@pytest.mark.parametrize("kind", ["simulate", "value_and_grad", "case"])
def test_the_estimate_bounds_the_measured_peak(kind, halved, monkeypatch):
    """The formula is an upper bound of what tracemalloc sees a run allocate (a scene with
    every term, a force schedule and the oscillator objective: the largest measured), on one
    thread and as two halves on two threads (:mod:`pes_ref.accel.halves`)."""
    import tracemalloc
    from pes_ref.accel import halves
    from pes_ref.core.runtime import pages
    if halved:
        monkeypatch.setattr(halves, "MIN_PARTICLES", 2)
    T, N = 2000, 30
    surf = pr.Surface(np.random.default_rng(0).uniform(0, 0.1, (12, 12)), (0, 0), (1, 1), (False, False))
    scene = pr.Scene(surf, dt=0.001, n_steps=T, damping=0.1, spring=pr.Spring(1.0, (0.5, 0.5)),
                     walls=pr.Walls(10.0, 0.1, np.ones((2, 2), bool)), effects=(pr.Constant((0.1, 0.0)),))
    x0 = np.random.default_rng(1).uniform(0.2, 0.8, (N, 2))
    case = dict(small_case(n_steps=T, n=N), x0=x0, values=surf.values, lower=np.zeros(2), upper=np.ones(2),
                dt=np.float64(0.001), spring_k=np.float64(1.0), spring_center=np.array([0.5, 0.5]),
                wall_k=np.float64(10.0), wall_margin=np.float64(0.1), walls=np.ones((2, 2), bool))
    run = {"simulate": lambda: pr.simulate(scene, x0),
           "value_and_grad": lambda: pr.value_and_grad(scene, x0, None, pr.Oscillator(0.3, 2.0)),
           "case": lambda: oracle.run_case(case)}[kind]
    monkeypatch.setattr(pages, "_FLAGS", None)      # every array NumPy's, which tracemalloc sees
    tracemalloc.start()
    try:
        run()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak <= budget.run_bytes(T, N, kind), (peak, budget.run_bytes(T, N, kind))


def test_a_run_that_cannot_fit_is_refused_at_the_boundary(monkeypatch):
    """simulate and value_and_grad refuse before allocating anything of the run's size:
    n_steps = 10**9 is refused, naming n_steps, N and the size in GiB, with less than a
    megabyte allocated (tracemalloc, every array NumPy's; the run would need 32 GB)."""
    import tracemalloc
    from pes_ref.core.runtime import pages
    monkeypatch.setattr(pages, "_FLAGS", None)      # every array NumPy's, which tracemalloc sees
    for run in (lambda s: pr.simulate(s, [[0.5, 0.5], [0.2, 0.3]]),
                lambda s: pr.value_and_grad(s, [[0.5, 0.5], [0.2, 0.3]], None, pr.Funnel(0.5))):
        scene = _scene(10 ** 9)
        tracemalloc.start()
        try:
            with pytest.raises(budget.RunTooLargeError) as info:
                run(scene)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert peak < 2 ** 20, peak
        msg = str(info.value)
        assert info.value.key == "n_steps" and "\n" not in msg
        assert "n_steps = 1000000000" in msg and "N = 2" in msg and "GiB" in msg, msg


def test_the_refusal_boundary_is_the_available_memory(monkeypatch):
    need = budget.run_bytes(100, 2, "simulate")
    monkeypatch.setattr(budget, "available_memory", lambda: need)
    pr.simulate(_scene(100), [[0.5, 0.5], [0.2, 0.3]])
    monkeypatch.setattr(budget, "available_memory", lambda: need - 1)
    with pytest.raises(budget.RunTooLargeError):
        pr.simulate(_scene(100), [[0.5, 0.5], [0.2, 0.3]])
    monkeypatch.setattr(budget, "available_memory", lambda: None)     # unknown: no refusal
    pr.simulate(_scene(100), [[0.5, 0.5], [0.2, 0.3]])


@pytest.mark.parametrize("names, flags, words", [
    ({}, {"n_steps": "--set n_steps"}, ("--set n_steps = 100 with N = 2 particles", "reduce --set n_steps or the number")),
    ({"particles": "n_particles"}, {"n_steps": "--set n_steps", "n_particles": "--particles"},
     ("--set n_steps = 100 with --particles = 2", "reduce --set n_steps or --particles")),
    ({"steps": "duration", "length": "duration = 0.1 (100 steps of dt 0.001)"}, {"duration": "--duration"},
     ("--duration = 0.1 (100 steps of dt 0.001) with N = 2 particles", "reduce --duration or")),
    ({"steps": "duration", "length": "duration = 0.1 (100 steps of dt 0.001)", "fixed_particles": True},
     {"duration": "--duration"}, ("with N = 2 particles", "memory available; reduce --duration")),
])
def test_the_refusal_names_the_arguments_that_set_the_run(monkeypatch, names, flags, words):
    from pes_ref.cli.common import flag_message
    monkeypatch.setattr(budget, "available_memory", lambda: 1)
    with pytest.raises(budget.RunTooLargeError) as info:
        budget.check_memory(100, 2, "simulate", **names)
    assert info.value.key == names.get("steps", "n_steps")
    text = flag_message(info.value, flags)
    for w in words:
        assert w in text
    assert text.endswith("the number of particles") != bool(names.get("fixed_particles") or names.get("particles"))


def test_validate_case_refuses_before_allocating_the_force(monkeypatch):
    """The oracle refuses n_steps = 10**9 naming the key; the (T+1, N, 2) force array is never built."""
    def no_force(*a, **k):
        raise AssertionError("the force array was allocated")
    monkeypatch.setattr(oracle, "_force", no_force)
    with pytest.raises(oracle.CaseError) as info:
        oracle.validate_case(small_case(n_steps=10 ** 9))
    assert info.value.key == "n_steps" and "GiB" in str(info.value)


def test_cli_oracle_refuses_a_run_too_large_in_one_line(tmp_path):
    path, out = tmp_path / "c.npz", tmp_path / "r.npz"
    oracle.save_case(path, **small_case(n_steps=10 ** 9))
    proc = run_cli("oracle", path, out)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == EXIT_ERROR and len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert lines[0].startswith("error: case key 'n_steps': ") and "n_steps = 1000000000" in lines[0]
    assert "N = 2" in lines[0] and "GiB" in lines[0]
    assert not out.exists()


# =========================================================================== progress in the hot loops

@pytest.mark.parametrize("mode, integrator", [("dynamic", "verlet"), ("dynamic", "gjf"), ("quasistatic", "verlet")])
def test_progress_is_reported_every_few_hundred_steps(mode, integrator):
    T = 3 * progress.EVERY + 17
    extra = dict(mobility=(0.01, 0.01)) if mode == "quasistatic" else dict(damping=0.2, integrator=integrator)
    scene = pr.Scene(pr.Surface(np.zeros((4, 4)), (0, 0), (1, 1), (False, False)), dt=0.01, n_steps=T,
                     mode=mode, **extra)
    calls = []
    traj = pr.simulate(scene, [[0.5, 0.5]], progress=lambda *a: calls.append(a))
    assert calls == [("forward", k, T) for k in (0, 256, 512, 768, T)]
    calls.clear()
    _, _, traj2 = pr.value_and_grad(scene, [[0.5, 0.5]], None, pr.Funnel(0.5), progress=lambda *a: calls.append(a))
    assert calls == [("forward", k, T) for k in (0, 256, 512, 768, T)] + [("adjoint", k, T)
                                                                          for k in (0, 256, 512, 768, T)]
    np.testing.assert_array_equal(traj.x, traj2.x)
    np.testing.assert_array_equal(traj.x, pr.simulate(scene, [[0.5, 0.5]]).x)   # reporting changes nothing


def test_the_time_estimate_grows_with_the_run():
    a = budget.estimate_seconds(1000, 10)
    assert 0 < a < budget.estimate_seconds(2000, 10) and a < budget.estimate_seconds(1000, 1000)
    assert budget.estimate_seconds(1000, 10, "simulate") < a


def test_a_short_run_is_estimated_without_measuring():
    """The ~50 ms calibration runs only for a run that the typical cost puts over a second."""
    budget.step_cost.cache_clear()
    budget.estimate(200, 4, "case")
    assert budget.step_cost.cache_info().misses == 0
    budget.estimate(10 ** 6, 64, "case")
    assert budget.step_cost.cache_info().misses == 1


def test_cli_oracle_prints_progress_lines(tmp_path, capsys, monkeypatch):
    """The oracle command's path, kept short: with the long-run threshold and the period
    lowered, a run of a few tenths of a second prints its estimate and progress lines on
    stderr, and the result on stdout."""
    from pes_ref.cli import main
    monkeypatch.setattr(progress, "LONG_RUN", 0.05)
    monkeypatch.setattr(progress, "PERIOD", 0.02)
    T, n = 20000, 2
    path, out = tmp_path / "c.npz", tmp_path / "r.npz"
    oracle.save_case(path, **dict(small_case(n_steps=T, n=n), values=np.zeros((5, 7))))   # flat: no chaos
    assert main(["oracle", str(path), str(out)]) == EXIT_OK
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert err and err[0].startswith(f"{path}: estimate | steps 0/{T} | N {n} | "), err
    assert any(" forward " in e and "left" in e for e in err[1:]) and any(" adjoint " in e for e in err[1:]), err
    assert captured.out.startswith(f"wrote {out}")


#: Runs the command line in a process of its own with the oracle's long-run threshold and
#: its period between progress lines set to 0: every run counts as long and every report of
#: the loops is printed, whatever the machine's speed.
_EVERY_REPORT = """
import sys
from pes_ref.cli import main
from pes_ref.core.runtime import progress
progress.LONG_RUN = progress.PERIOD = 0.0
sys.exit(main())
"""


def test_an_oracle_process_prints_its_estimate_and_progress(tmp_path):
    """The whole path of a long run in a real process: the estimate first, then progress
    lines of the forward loop and of the adjoint on stderr, the result on stdout."""
    T, n = 3000, 2
    path, out = tmp_path / "c.npz", tmp_path / "r.npz"
    oracle.save_case(path, **dict(small_case(n_steps=T, n=n), values=np.zeros((5, 7))))   # flat: no chaos
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-c", _EVERY_REPORT, "oracle", str(path), str(out)], capture_output=True,
                          text=True, env=env, timeout=120)
    assert proc.returncode == EXIT_OK, proc.stderr
    assert proc.stdout.startswith(f"wrote {out}")
    err = proc.stderr.strip().splitlines()
    assert err and err[0].startswith(f"{path}: estimate | steps 0/{T} | N {n} | "), proc.stderr
    assert all(progress.is_progress_line(line) for line in err), err
    assert any(" forward " in e and "left" in e for e in err[1:]) and any(" adjoint " in e for e in err[1:]), err


def test_a_short_oracle_run_prints_nothing_on_stderr(tmp_path):
    path, out = tmp_path / "c.npz", tmp_path / "r.npz"
    oracle.save_case(path, **small_case())
    proc = run_cli("oracle", path, out)
    assert proc.returncode == EXIT_OK and without_progress(proc.stderr) == ""
