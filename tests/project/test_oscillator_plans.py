"""validation/experiments/oscillator_plans.py: its objective's gradient, the hand-drawn
escapement's documented score, and every kind of plan at smoke size."""
from __future__ import annotations

import json

import numpy as np
import pytest

from pes_ref import synthesis
from pes_ref.core.objectives import Oscillator
from pes_ref.testing.finite_differences import central_gradient
from pes_ref.oracle.compare import relative_error
from pes_ref.oracle.tolerances import FD_RTOL, TRAJ_RTOL

from _helpers import ROOT, load_script

plans = load_script(ROOT / "validation" / "experiments" / "oscillator_plans.py")

#: The hand-drawn escapement's held-out captured share, as docs/synthesis.md reports it.
ESCAPEMENT_CAPTURED = 0.88


def _trajectory(seed, T=40, N=3, dt=0.3):
    rng = np.random.default_rng(seed)
    return rng.normal(0, 1, (T, N, 2)), rng.normal(0, 1, (T, N, 2)), np.arange(T) * dt


@pytest.mark.parametrize("omega", [1.0, 1.7])
@pytest.mark.parametrize("seed", [0, 1])
def test_window_phase_gradient_matches_central_differences(omega, seed):
    """Both derivatives, including the path through the fitted phases, several windows (one partial)."""
    x, v, t = _trajectory(seed)
    obj = plans.WindowPhase(1.3, omega, 2 * np.pi / omega)
    _, gx, gv = obj.value_and_grad(x, v, t)
    fd_x = central_gradient(lambda z: obj.value_and_grad(z, v, t)[0], x)
    fd_v = central_gradient(lambda z: obj.value_and_grad(x, z, t)[0], v)
    assert np.max(np.abs(fd_x[..., 0])) > 0 and np.max(np.abs(fd_v[..., 0])) > 0
    assert relative_error(gx, fd_x) < FD_RTOL
    assert relative_error(gv, fd_v) < FD_RTOL
    np.testing.assert_array_equal(gx[..., 1], 0.0)


def test_window_phase_is_zero_on_the_cycle_at_any_phase_per_window():
    """A harmonic oscillation of amplitude A costs nothing, whatever its phase, which may jump between windows."""
    A, w = 1.5, 1.0
    t = np.arange(300) * 0.05                        # 2.4 windows of 2 pi
    phase = np.where(t < 2 * np.pi, 0.4, 2.0)[:, None] + np.array([0.0, 1.0, -2.5])
    x, v = np.zeros((300, 3, 2)), np.zeros((300, 3, 2))
    x[:, :, 0] = A * np.cos(w * t[:, None] + phase)
    v[:, :, 0] = -A * w * np.sin(w * t[:, None] + phase)
    value, _, _ = plans.WindowPhase(A, w, 2 * np.pi / w).value_and_grad(x, v, t)
    assert value == pytest.approx(0.0, abs=1e-12)


def test_window_phase_equals_eq6_at_the_reference_phase():
    """In phase with eq. (6)'s reference (phase 0 in every window) the two costs agree."""
    A, w = 1.0, 1.0
    t = np.arange(200) * 0.05
    rng = np.random.default_rng(3)
    amp = 0.7 + 0.1 * rng.random((1, 4))             # constant amplitude, phase 0: fitted phase is 0
    x, v = np.zeros((200, 4, 2)), np.zeros((200, 4, 2))
    x[:, :, 0] = amp * np.cos(w * t[:, None])
    v[:, :, 0] = -amp * w * np.sin(w * t[:, None])
    got = plans.WindowPhase(A, w, 2 * np.pi).value_and_grad(x, v, t)[0]
    want = Oscillator(A, w).value_and_grad(x, v, t)[0]
    assert got == pytest.approx(want, rel=TRAJ_RTOL * 1e3)


def test_escapement_scores_what_the_docs_say():
    """The hand-drawn escapement (no optimization) on the default problem: the documented 0.88."""
    problem = synthesis.OscillatorProblem()
    values = synthesis.escapement_values(problem)
    assert values.shape == (32, 32) and np.isfinite(values).all()
    assert plans.held_out(problem, values)["captured"] == pytest.approx(ESCAPEMENT_CAPTURED, abs=0.005)


@pytest.mark.parametrize("plan", ["default", "cycle_starts", "tbptt_rest", "escapement_window", "torque_widen", "basis_fourier_legendre", "fixed_batch_backtrack",
                                  "rescaled_scene"])
def test_plan_smoke_writes_its_record(plan, tmp_path, capsys):
    assert plans.main([plan, "--smoke", "--out", str(tmp_path)]) == 0
    record = json.loads((tmp_path / f"{plan}_s0.json").read_text())
    assert record["plan"] == plan and len(record["loss"]) == 4
    assert [c["iteration"] for c in record["checkpoints"]][-1] == 4
    assert all(np.isfinite(record["loss"]))
    grids = np.load(tmp_path / f"{plan}_s0.npz")
    assert "it4" in grids.files and np.isfinite(grids["it4"]).all()
    assert "final (it 4)" in capsys.readouterr().out


def test_plan_refuses_to_overwrite(tmp_path, capsys):
    assert plans.main(["default", "--smoke", "--out", str(tmp_path)]) == 0
    before = (tmp_path / "default_s0.json").read_bytes()
    with pytest.raises(SystemExit) as exc:
        plans.main(["default", "--smoke", "--out", str(tmp_path)])
    assert exc.value.code == 2
    assert "--force" in capsys.readouterr().err
    assert (tmp_path / "default_s0.json").read_bytes() == before


@pytest.mark.parametrize("argv, word", [(["nope"], "plan"), (["default", "--seed", "-1"], "--seed"),
                                        (["default", "--stop", "0"], "--stop"),
                                        (["default", "--iterations", "0"], "--iterations")])
def test_plan_bad_arguments(argv, word, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        plans.main(argv + ["--out", str(tmp_path)])
    assert exc.value.code == 2
    assert word in capsys.readouterr().err


def test_all_runs_every_plan_not_in_the_sweep_file_and_summarizes(tmp_path, capsys):
    assert plans.main(["--all", "--smoke", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "default" in plans.SWEPT and "window" not in plans.SWEPT
    for name in plans.PLANS:
        assert (tmp_path / f"{name}_s0.json").exists() == (name not in plans.SWEPT)     # the sweep runs those
        assert (f"| {name} | 0 |" in out) == (name not in plans.SWEPT)
    assert plans.main(["--all", "--smoke", "--out", str(tmp_path)]) == 0     # all there: nothing reruns
    assert "plan window" not in capsys.readouterr().out


def test_snr_table_smoke(capsys):
    assert plans.main(["--snr", "--smoke"]) == 0
    out = capsys.readouterr().out
    assert out.count("\n| ") >= len(plans.PLANS)



def test_basis_gradient_matches_central_differences():
    """``B^T dL/dE`` is the gradient of the loss with respect to the basis coefficients."""
    s = plans.smoke_setting(plans.PLANS["basis_fourier_legendre"])
    problem = plans.problem_of(s)
    B = plans.basis_matrix((8, 8), 2, 3)
    theta = np.random.default_rng(0).standard_normal(B.shape[-1]) * 0.05
    objective = plans.objective_of(s, problem)

    def loss(th, grad=False):
        x0, v0, scene = plans.batch(s, problem, B @ th, np.random.default_rng([0, 0]), 0, 40)
        value, grads, _ = plans.value_and_grad(scene, x0, v0, objective, wrt=("values",))
        return (value, np.tensordot(B, grads["values"], axes=([0, 1], [0, 1]))) if grad else value

    _, g = loss(theta, grad=True)
    fd = central_gradient(loss, theta)
    assert np.max(np.abs(fd)) > 0
    assert relative_error(g, fd) < FD_RTOL


def test_rank_smoke(tmp_path, capsys):
    np.savez(tmp_path / "g.npz", a=np.zeros((8, 8)))
    assert plans.main(["--rank", f"{tmp_path / 'g.npz'}:a", "--smoke"]) == 0
    out = capsys.readouterr().out
    assert "| flat |" in out and "| escapement |" in out and "g.npz:a |" in out
    with pytest.raises(SystemExit):
        plans.main(["--rank", f"{tmp_path / 'g.npz'}:missing", "--smoke"])
    assert "no grid 'missing'" in capsys.readouterr().err
