"""Every figure script runs with --smoke into a temporary folder and writes a non-trivial PNG
and a PDF; the ``make figures`` cache is reused only when its inputs are unchanged.

The designs are tiny ones made in-process by the project's own command
(``python -m pes_ref design KIND --smoke``), not the full designs.
"""
from __future__ import annotations

import importlib
import json
import os
import shutil
import sys

import numpy as np
import pytest

from pes_ref.cli import main as cli_main

from matplotlib.image import imread

from figures import make_all   # the package beside pes_ref (the repository is on pytest's pythonpath: setup.cfg)

#: A PNG smaller than this many bytes cannot hold labelled axes and data (the coarse
#: smoke PNGs of our figures are 15 kB and more; an empty figure with a title is ~2 kB).
MIN_PNG_BYTES = 8_000
#: Standard deviation of the grey levels (0..1) below which an image is blank or one flat colour.
MIN_PIXEL_STD = 0.05

FIGURES = [(name, kind) for name, kind in make_all.FIGURES]


@pytest.fixture(scope="module")
def smoke_designs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("designs")
    out = {}
    for kind in sorted({kind for _, kind in make_all.FIGURES if kind}):
        path = str(folder / f"{kind}.npz")
        assert cli_main([*make_all.DESIGNS[kind], "--smoke", "--quiet", "--out", path]) == 0
        out[kind] = path
    return out


@pytest.mark.parametrize("name,kind", FIGURES, ids=[n for n, _ in FIGURES])
def test_figure_smoke(name, kind, smoke_designs, tmp_path):
    module = importlib.import_module(f"figures.{name}")
    argv = ["--smoke", "--out", str(tmp_path)] + (["--design", smoke_designs[kind]] if kind else [])
    assert module.main(argv) == 0
    png = tmp_path / f"{module.NAME}.png"
    assert png.stat().st_size > MIN_PNG_BYTES
    img = imread(str(png))[..., :3].mean(axis=-1)
    assert img.std() > MIN_PIXEL_STD
    import matplotlib.pyplot as plt
    assert plt.get_fignums() == []          # every figure closed


def test_figure_names_are_unique_and_numbered():
    names = [importlib.import_module(f"figures.{n}").NAME for n, _ in FIGURES]
    # the paper's eleven, then beyond the paper: fig12 (the held-out torque sweep, torque by torque)
    # fig13 (the latch of a problem file), fig14 (the funnel realized by contact) and fig15 (the
    # latch realized by contact)
    assert sorted(n[:5] for n in names) == [f"fig{i:02d}" for i in range(1, 16)]


def test_design_figure_refuses_wrong_kind(smoke_designs, tmp_path):
    module = importlib.import_module("figures.fig06_funnel_surface")
    with pytest.raises(SystemExit, match="oscillator design"):
        module.main(["--smoke", "--out", str(tmp_path), "--design", smoke_designs["oscillator"]])


def test_design_gradient_is_zero_where_no_particle_passes(smoke_designs):
    """What Fig. 5 shows: dL/dE is nonzero only at nodes of cells a path visits."""
    from pes_ref.synthesis import design_gradient
    from pes_ref.synthesis.engine.design_file import load_design
    from pes_ref.core.surface import Surface
    from figures.fig05_funnel_gradient import visited_nodes
    state = load_design(smoke_designs["funnel"])
    p = state.problem
    step = design_gradient(p, state.values, seed=state.seed, iteration=state.iteration, n_particles=4)
    visited = visited_nodes(Surface(state.values, p.lower, p.upper, p.periodic), step.traj.x)
    assert np.any(step.grad != 0)
    assert not visited.all()                     # the test can fail: some nodes are not visited
    assert np.count_nonzero(step.grad[~visited]) == 0


def _sidecar(npz, key):
    side = npz[:-4] + ".json"
    with open(side, "w") as fh:
        json.dump({"key": key, "sha256": make_all.file_hash(npz)}, fh)
    return side


def test_cache_reused_only_when_inputs_unchanged(smoke_designs, tmp_path):
    npz = str(tmp_path / "funnel.npz")
    shutil.copy(smoke_designs["funnel"], npz)
    sources = make_all.source_hash()
    key = make_all.cache_key(sources, ["design", "funnel"])
    side = _sidecar(npz, key)
    assert make_all.cache_valid(npz, side, key)
    # another command line, other sources: another key
    assert make_all.cache_key(sources, ["design", "funnel", "--smoke"]) != key
    assert make_all.cache_key("0" * 64, ["design", "funnel"]) != key
    assert not make_all.cache_valid(npz, side, make_all.cache_key("0" * 64, ["design", "funnel"]))
    # the design file changed after the sidecar was written
    with open(npz, "ab") as fh:
        fh.write(b"\0")
    assert not make_all.cache_valid(npz, side, key)
    os.remove(side)
    assert not make_all.cache_valid(npz, side, key)


def test_cache_refuses_unfinished_design(tmp_path):
    from pes_ref.synthesis import new_design
    from pes_ref.synthesis.engine.design_file import save_design
    npz = str(tmp_path / "osc.npz")
    save_design(npz, new_design("oscillator", grid0=8, grid1=8))       # status "running", as a checkpoint is
    key = make_all.cache_key("s", ["design", "oscillator"])
    assert not make_all.cache_valid(npz, _sidecar(npz, key), key)


def test_schedule_runs_steps_and_skips_what_a_failed_step_needs():
    log = make_all.Log()
    bad = make_all.Step("design funnel", [sys.executable, "-c", "raise SystemExit(3)"])
    needs_bad = make_all.Step("fig05", [sys.executable, "-c", "print('drawn')"], needs="design funnel")
    free = make_all.Step("fig01", [sys.executable, "-c", "print('drawn')"])
    make_all.schedule([bad, needs_bad, free], 2, log)
    assert bad.status == "failed (exit 3)"
    assert needs_bad.status.startswith("skipped (design funnel failed")
    assert free.status == "done" and free.seconds > 0
    assert not make_all.succeeded(bad) and make_all.succeeded(free)


def test_fig12_draws_the_default_beside_the_gradient_descent_design(tmp_path):
    designs = {name: f"{name}.npz" for name in make_all.DESIGNS}
    assert make_all.DESIGNS["oscillator"] == ["design", "oscillator"]                     # the command's defaults
    assert make_all.DESIGNS["oscillator_overshoot"][-2:] == ["--plan", "overshoot"]
    steps = {s.name: s for s in make_all.figure_steps(str(tmp_path), False, designs, None)}
    fig12 = steps["fig12_torque_capture"]
    assert set(fig12.needs) == {"design oscillator", "design oscillator_overshoot"}
    assert fig12.argv[-4:] == ["--design", "oscillator.npz", "--baseline", "oscillator_overshoot.npz"]
    assert steps["fig08_oscillator"].needs == ("design oscillator",)
