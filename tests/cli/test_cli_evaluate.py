"""``python -m pes_ref evaluate --json`` and ``--plot`` on small designs of every kind (``--smoke``)."""
import json
import math

import numpy as np
import pytest
from matplotlib.image import imread

import _helpers
import pes_ref.synthesis
from pes_ref.cli import EXIT_ERROR, EXIT_OK, main
from pes_ref.synthesis import load_design
from pes_ref.synthesis import held_out_panels

#: The design of each kind, as ``design`` makes it (the oscillator without its polish: quicker).
DESIGNS = {"funnel": ["funnel", "--smoke"], "oscillator": ["oscillator", "--smoke", "--plan", "eq6"],
           "latch": ["latch", "--smoke"]}
#: Few held-out particles: the tests are of the files, not of the designs.
PARTICLES = ["--particles", "8"]


def run(capsys, *argv):
    code = main(list(map(str, argv)))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def designs(tmp_path_factory):
    """A design file of each kind, made once."""
    folder = tmp_path_factory.mktemp("designs")
    for name, argv in DESIGNS.items():
        assert main(["design", *argv, "--quiet", "--out", str(folder / f"{name}.npz")]) == EXIT_OK
    return folder


def _strict(text: str):
    """JSON as a strict reader reads it: NaN and Infinity are not JSON."""
    def refuse(word):
        raise ValueError(f"{word} is not JSON")
    return json.loads(text, parse_constant=refuse)


@pytest.mark.parametrize("name", list(DESIGNS))
def test_json_holds_the_printed_lines(name, designs, tmp_path, capsys):
    path = tmp_path / "figures.json"
    code, out, err = run(capsys, "evaluate", designs / f"{name}.npz", *PARTICLES, "--seed", 9191, "--json", path)
    assert code == EXIT_OK, err
    assert f"wrote {path} (figures)" in err
    data = _strict(path.read_text())
    printed = dict(line.split(": ", 1) for line in out.splitlines())
    assert data["seed"] == 9191 and data["particles"] == int(float(printed["particles"]))
    header = ("kind", "problem", "method", "stage", "iterations", "grid_iteration", "screened_starts",
              "screened_iterations", "evaluations", "status")
    assert {key: str(data[key]) for key in header if key in printed} == {k: printed[k] for k in header if k in printed}
    assert (data["problem"] is None) == ("problem" not in printed)
    figures = {k: v for k, v in printed.items() if k not in header}
    assert list(data["figures"]) == list(figures)
    for key, text in figures.items():
        value = data["figures"][key]
        if text == "nan":
            assert value is None, key
        else:
            assert value == pytest.approx(float(text), rel=1e-5, abs=1e-12), key


def test_a_validated_design_says_which_iterations_grid_it_scored(tmp_path, capsys):
    # every particle passes on the starting grid, so the first validation (iteration 0) stays the
    # best (the first of equals) and the design delivers that grid after 3 iterations
    text = _helpers.gather_problem(radius=5.0, iterations=3).replace(
        "particles = 6", "particles = 6\nvalidate_every = 1\nvalidation_particles = 4")
    (tmp_path / "p.toml").write_text(text)
    assert main(["design", str(tmp_path / "p.toml"), "--quiet", "--out", str(tmp_path / "d.npz")]) == EXIT_OK
    capsys.readouterr()
    code, out, err = run(capsys, "evaluate", tmp_path / "d.npz", *PARTICLES, "--json", tmp_path / "d.json")
    assert code == EXIT_OK, err
    printed = dict(line.split(": ", 1) for line in out.splitlines())
    assert printed["iterations"] == "3" and printed["grid_iteration"] == "0"
    data = _strict((tmp_path / "d.json").read_text())
    assert data["iterations"] == 3 and data["grid_iteration"] == 0


def test_a_nan_figure_is_null(designs, tmp_path, capsys):
    """The smoke oscillator captures nothing: its errors over the captured particles are NaN."""
    path = tmp_path / "o.json"
    code, out, err = run(capsys, "evaluate", designs / "oscillator.npz", *PARTICLES, "--json", path)
    assert code == EXIT_OK, err
    assert "amplitude_error: nan" in out
    assert _strict(path.read_text())["figures"]["amplitude_error"] is None
    assert '"amplitude_error": null' in path.read_text()


@pytest.mark.parametrize("option, target", [("--json", "kept.json"), ("--plot", "plots")])
def test_an_existing_output_is_refused_before_computing_unless_force(option, target, designs, tmp_path, capsys,
                                                                     monkeypatch):
    kept = tmp_path / target
    if option == "--plot":
        kept.mkdir()
        (kept / "funnel_paths.png").write_bytes(b"a user's own picture")
        existing = kept / "funnel_paths.png"
    else:
        kept.write_text("a user's own notes\n")
        existing = kept
    before = existing.read_bytes()
    calls = []
    real = pes_ref.synthesis.evaluate
    monkeypatch.setattr(pes_ref.synthesis, "evaluate", lambda *a, **k: calls.append(1) or real(*a, **k))
    code, out, err = run(capsys, "evaluate", designs / "funnel.npz", *PARTICLES, option, kept)
    assert code == EXIT_ERROR and not calls and out == ""
    assert err.startswith(f"error: {option} {kept}: ") and "exists already" in err and err.count("\n") == 1, err
    assert existing.read_bytes() == before
    code, out, err = run(capsys, "evaluate", designs / "funnel.npz", *PARTICLES, option, kept, "--force")
    assert code == EXIT_OK and calls, err
    assert existing.read_bytes() != before


@pytest.mark.parametrize("name", list(DESIGNS))
def test_plot_draws_the_held_out_paths(name, designs, tmp_path, capsys):
    folder = tmp_path / "new" / "plots"
    folder.parent.mkdir()
    code, out, err = run(capsys, "evaluate", designs / f"{name}.npz", *PARTICLES, "--plot", folder)
    assert code == EXIT_OK, err
    png = folder / f"{name}_paths.png"
    assert f"wrote {png} (held-out paths)" in err and sorted(p.name for p in folder.iterdir()) == [png.name]
    assert png.stat().st_size > 20_000
    image = imread(png)
    assert image.ndim == 3 and image.shape[0] > 300 and image.shape[1] > 400
    assert np.ptp(image[..., :3]) > 0.5                 # not a blank page


def test_a_problem_files_panels_are_each_test_and_all_of_them(designs):
    state = load_design(designs / "latch.npz")
    panels = held_out_panels(state.problem, state.values, seed=5, n_particles=8)
    names = [name for name, _ in state.problem.tests]
    assert len(panels) == len(names) + 1 and panels[0].title == "every success test"
    assert all(f"success test {n} " in p.title for n, p in zip(names, panels[1:]))
    assert all(p.x.shape[1:] == (8, 2) and p.passed.shape == (8,) for p in panels)
    assert np.array_equal(panels[0].passed, np.logical_and.reduce([p.passed for p in panels[1:]]))


@pytest.mark.parametrize("name, title", [("funnel", "exit in the band"), ("oscillator", "captured")])
def test_the_built_in_kinds_panels(name, title, designs):
    state = load_design(designs / f"{name}.npz")
    panels = held_out_panels(state.problem, state.values, n_particles=8)
    assert panels and all(title in p.title and p.passed.dtype == bool for p in panels)
    assert not math.isnan(float(np.mean(panels[0].passed)))


# ------------------------------------------------------------------ --realized --engine
@pytest.fixture(scope="module")
def realized(designs):
    """The smoke funnel realized by contact: (design file, device file)."""
    pytest.importorskip("shapely")
    out = designs / "funnel_parts"
    assert main(["realize", str(designs / "funnel.npz"), "--as", "contact", "--out", str(out)]) == EXIT_OK
    return designs / "funnel.npz", out / "device.toml"


def test_engine_both_prints_the_design_the_surface_and_the_rigid_figures_and_their_difference(realized, capsys):
    pytest.importorskip("pymunk")
    design, device = realized
    code, out, err = run(capsys, "evaluate", design, "--realized", device, "--engine", "both", *PARTICLES)
    assert code == EXIT_OK, err
    lines = dict(line.split(": ", 1) for line in out.splitlines())
    for name in ("in_band_fraction", "exited_fraction", "dt", "n_steps"):
        assert {name, f"realized_{name}", f"rigid_{name}"} <= lines.keys()
    difference = float(lines["rigid_in_band_fraction"]) - float(lines["realized_in_band_fraction"])
    assert float(lines["rigid_minus_realized_in_band_fraction"]) == pytest.approx(difference, abs=1e-6)
    assert "rigid_minus_realized_dt" not in lines
    # bit-identical on repeat (every line but the wall time)
    again = run(capsys, "evaluate", design, "--realized", device, "--engine", "both", *PARTICLES)[1]
    assert [x for x in out.splitlines() if not x.startswith("seconds")] == \
        [x for x in again.splitlines() if not x.startswith("seconds")]
    # --engine rigid alone: the rigid lines, no surface-realized ones, the same numbers
    code, alone, err = run(capsys, "evaluate", design, "--realized", device, "--engine", "rigid", *PARTICLES)
    assert code == EXIT_OK, err
    rigid = dict(line.split(": ", 1) for line in alone.splitlines())
    assert rigid["rigid_in_band_fraction"] == lines["rigid_in_band_fraction"]
    assert not any(name.startswith("realized_") for name in rigid)


@pytest.mark.parametrize("argv, words", [
    (["--engine", "soft"], "--engine 'soft': expected one of surface, rigid, both"),
    (["--engine", "rigid", "--no-realized"], "--engine rigid runs a realized device's parts: it needs --realized"),
])
def test_a_bad_engine_is_one_line_naming_the_flag(realized, capsys, argv, words):
    design, device = realized
    argv = [a for a in argv if a != "--no-realized"] + ([] if "--no-realized" in argv else ["--realized", device])
    code, out, err = run(capsys, "evaluate", design, *argv, *PARTICLES)
    assert code == EXIT_ERROR and out == ""
    assert err.count("\n") == 1 and words in err


def test_the_rigid_engine_without_pymunk_is_one_line_with_the_pip_line(realized, capsys, monkeypatch):
    import sys
    monkeypatch.setitem(sys.modules, "pymunk", None)
    design, device = realized
    code, out, err = run(capsys, "evaluate", design, "--realized", device, "--engine", "both", *PARTICLES)
    assert code == EXIT_ERROR and out == ""
    assert err.count("\n") == 1 and "pip install 'pes_ref[rigid]'" in err
