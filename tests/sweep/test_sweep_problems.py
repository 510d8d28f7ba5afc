"""A sweep whose base is a problem file: its runs, their ids, the refusals, and one run as a
worker does it (the problem travels as text, so a worker needs no file)."""
from __future__ import annotations

import pytest

import _helpers

from pes_ref.sweep import task as task_module
from pes_ref.sweep.spec import SweepFileError, load_sweep
from pes_ref.synthesis import load_design

GATHER = _helpers.gather_problem()

SWEEP = """\
problem = "gather.toml"
seeds = [0, 1]
eval_seeds = [12345]
[base]
iterations = 3
[grid]
"dynamics.damping" = [0.5, 1.0]
"""


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "gather.toml").write_text(GATHER)
    (tmp_path / "s.toml").write_text(SWEEP)
    return tmp_path


def test_runs_of_a_problem_file(folder):
    sweep = load_sweep(folder / "s.toml")
    assert sweep.kind == "problem" and sweep.problem.name == "gather" and len(sweep.runs) == 4
    assert sweep.axes == ("dynamics.damping",)
    ids = {r.id for r in sweep.runs}
    (folder / "gather.toml").write_text(GATHER.replace("radius = 0.3", "radius = 0.25"))
    assert {r.id for r in load_sweep(folder / "s.toml").runs}.isdisjoint(ids)     # another problem, other runs
    (folder / "gather.toml").write_text("# a comment\n" + GATHER)
    assert {r.id for r in load_sweep(folder / "s.toml").runs} == ids              # the same problem


@pytest.mark.parametrize("text, where", [
    ('problem = "nothing.toml"\neval_seeds = [1]\n', "problem: "),
    ('problem = "gather.toml"\nkind = "funnel"\neval_seeds = [1]\n', "kind: give kind or problem, not both"),
    ('problem = "gather.toml"\neval_seeds = [1]\n[base]\ndamping = 1.0\n', "base.damping: unknown option"),
    ('problem = "gather.toml"\neval_seeds = [1]\n[base]\n"dynamics.dt" = -1.0\n',
     "gather.toml: dynamics.dt: expected a number > 0"),
    ('problem = "gather.toml"\neval_seeds = [1]\n[base]\nplan = "eq6"\n', "only the oscillator has named plans"),
])
def test_a_bad_sweep_of_a_problem_file_gets_one_line(folder, text, where):
    (folder / "bad.toml").write_text(text)
    with pytest.raises(SweepFileError) as err:
        load_sweep(folder / "bad.toml")
    assert where in str(err.value) and "\n" not in str(err.value), str(err.value)


def test_a_run_as_a_worker_does_it_needs_no_file(folder, tmp_path_factory):
    sweep = load_sweep(folder / "s.toml")
    run = sweep.runs[1]
    elsewhere = tmp_path_factory.mktemp("worker")
    payload = run.payload(sweep, str(elsewhere / "run.npz"))
    (folder / "gather.toml").unlink()                          # the worker never reads it
    out = task_module.run_task(payload)
    assert out["status"] == "ok", out["error"]
    assert 0.0 <= out["figures"][12345]["success_fraction"] <= 1.0
    state = load_design(elsewhere / "run.npz")
    assert state.iteration == 3 and state.problem.dt == 0.05
    assert state.problem.data["dynamics"]["damping"] == run.options["dynamics.damping"]
    again = task_module.run_task(payload)                        # finished: only evaluated again
    assert again["status"] == "ok" and again["from_iteration"] == 3
