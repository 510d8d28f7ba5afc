"""Smoke tests of the benchmark (``python -m pes_ref bench``) and the check that
its autograd gradient agrees with pes_ref's (autograd is in the ``test`` extra). JAX is
large and only in the ``bench`` extra: ``make bench`` installs it, and the benchmark
itself fails (exit 1) when JAX's or autograd's gradient differs from pes_ref's, as the
last test here shows. Nothing here is timed: timings are what the benchmark prints, never
a pass/fail criterion."""
import json

import numpy as np
import pytest

from pes_ref import cli
from pes_ref.bench import cases as bench_cases
from pes_ref.oracle.tolerances import GRAD_RTOL

SECTIONS = ("scaling", "memory", "effects", "exponents", "design", "targets", "machine", "versions", "date")


def test_bench_quick_writes_json_and_plot(tmp_path, capsys):
    out = tmp_path / "b.json"
    assert cli.main(["bench", "--quick", "--no-autodiff", "--out", str(out)]) == cli.EXIT_OK
    res = json.loads(out.read_text())
    assert all(key in res for key in SECTIONS)
    assert {(r["mode"], r["N"]) for r in res["scaling"]} == {(m, n) for m in ("dynamic", "quasistatic") for n in (1, 4)}
    assert all(r["forward"]["min"] <= r["forward"]["median"] <= r["forward"]["max"] for r in res["scaling"])
    assert [r["effect"] for r in res["effects"]["rows"]][0] == "bare" and len(res["effects"]["rows"]) == 9
    assert all(r["autograd"]["status"] == "skipped" for r in res["design"])
    assert (tmp_path / "b-scaling.png").stat().st_size > 0
    printed = capsys.readouterr().out
    assert "Targets (docs/performance.md)" in printed and "bare scene / loop written for it alone" in printed


def test_bench_refuses_to_replace_a_named_file(tmp_path, capsys):
    out = tmp_path / "b.json"
    out.write_text("mine")
    assert cli.main(["bench", "--quick", "--out", str(out)]) == cli.EXIT_ERROR
    assert out.read_text() == "mine"
    assert "--force" in capsys.readouterr().err


def _tiny(name):
    kw = dict(funnel=dict(n_particles=3, n_steps=8, grid=9), oscillator=dict(n_particles=3, n_steps=8, grid=(6, 7)))
    return bench_cases.CASES[name](**kw[name])


def _agrees(module, name):
    case = _tiny(name)
    loss, grad = bench_cases.reference_gradient(case)
    got_loss, got = module.gradient_fn(case)(case.values)
    assert np.abs(grad).max() > 0
    assert abs(got_loss - loss) <= GRAD_RTOL * abs(loss)
    assert np.abs(got - grad).max() <= GRAD_RTOL * np.abs(grad).max()


@pytest.mark.parametrize("name", ["funnel", "oscillator"])
def test_autograd_version_gives_the_reference_gradient(name):
    from pes_ref.bench import with_autograd as bench_autograd
    assert bench_autograd.available()
    _agrees(bench_autograd, name)


def test_bench_quick_reports_every_backend_and_what_a_scene_does_not_name(tmp_path, capsys):
    """Both backends side by side (scaling, effects, design gradients, the design run); the
    terms named with zero coefficients; the arrays zero-filled; the new targets printed."""
    from pes_ref.core import backends
    out = tmp_path / "b.json"
    assert cli.main(["bench", "--quick", "--no-autodiff", "--out", str(out)]) == cli.EXIT_OK
    res = json.loads(out.read_text())
    installed = [b for b in ("numpy", "numba") if backends.installed(b)]
    assert sorted({r["backend"] for r in res["scaling"]}) == sorted(installed)
    assert all(sorted(r["backends"]) == sorted(installed) for r in res["design"])
    assert [r["N"] for r in res["design"] if r["case"] == "funnel"][-1] == 8          # the funnel at scale (quick: 8)
    assert [r["backend"] for r in res["runs"]] == installed and all(r["status"] == "done" for r in res["runs"])
    nothing = {r["effect"] for r in res["effects"]["nothing"]}
    assert {"spring, k = 0", "noise, std 0", "cylinder: spring k = (1, 0)"} <= nothing
    filled = res["memory"]["zero_filled"]
    assert {(r["mode"], r["call"]) for r in filled} >= {("dynamic", "value_and_grad"), ("quasistatic", "simulate")}
    assert all(len(r["arrays"]) == r["needed"] for r in filled)
    names = {t["target"] for t in res["targets"]}
    assert "trajectory-sized arrays filled, not needed" in names
    every = res["every_gradient"]                     # run_case's every gradient, each backend (JAX skipped)
    assert [r["n"] for r in every] == [4] and sorted(every[0]["seconds"]) == sorted(installed)
    assert {f"funnel gradient N = {n}: {b} / JAX steady" for n in (64, 4096, 65536) for b in installed} <= names
    printed = capsys.readouterr().out
    assert "Named with zero coefficients" in printed and "Design runs" in printed


def test_bench_fails_when_a_framework_gradient_differs(tmp_path, capsys, monkeypatch):
    """The benchmark checks every framework's gradient (autograd here, JAX under make
    bench) against pes_ref's before timing it: a wrong one is exit 1 and one error line."""
    from pes_ref.bench import with_autograd as bench_autograd
    right = bench_autograd.gradient_fn

    def wrong(case):
        fn = right(case)
        return lambda values: (lambda lg: (lg[0], 1.01 * lg[1]))(fn(values))
    monkeypatch.setattr(bench_autograd, "gradient_fn", wrong)
    assert cli.main(["bench", "--quick", "--out", str(tmp_path / "b.json")]) == cli.EXIT_FAIL
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: the design gradient differs from pes_ref's: funnel by autograd") and \
        err.count("\n") == 0, err
