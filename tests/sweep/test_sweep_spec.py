"""Sweep files (pes_ref.sweep.spec) and the design options they share with ``design`` (pes_ref.sweep.options).

No Dask here: reading, checking and expanding a file, and the one-line errors."""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import pytest

from pes_ref.cli import build_parser
from pes_ref.sweep import options as opt
from pes_ref.sweep.results import _TAIL
from pes_ref.sweep.spec import TOP_LEVEL_KEYS, SweepFileError, load_sweep, parse_sweep
from pes_ref.synthesis import KINDS, DESIGN_OPTIONS, OscillatorProblem, design_inputs

ROOT = Path(__file__).resolve().parents[2]
EXPERIMENTS = ROOT / "validation" / "experiments"


def write(tmp_path, text, name="s.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


BASE = 'kind = "funnel"\neval_seeds = [12345]\n'


def test_grid_times_variants_times_seeds(tmp_path):
    path = write(tmp_path, BASE + '''seeds = [0, 1, 2]
[base]
smoke = true
iterations = 4
[grid]
lr = [0.001, 0.002]
noise = [0.1, 0.2]
[[variants]]
name = "adam"
optimizer = "adam"
[[variants]]
name = "rms"
''')
    sweep = load_sweep(path)
    assert len(sweep.runs) == 2 * 2 * 2 * 3
    assert sweep.axes == ("variant", "lr", "noise") and sweep.name == "s"
    assert set(sweep.swept) == {"variant", "lr", "noise", "optimizer"}
    first = sweep.runs[0]
    assert first.variant == "adam" and first.seed == 0
    assert first.options == {"smoke": True, "iterations": 4, "optimizer": "adam", "lr": 0.001, "noise": 0.1}
    assert len({r.id for r in sweep.runs}) == len(sweep.runs)
    assert sorted({r.seed for r in sweep.runs}) == [0, 1, 2]


def test_run_id_depends_on_the_design_only(tmp_path):
    """The same run keeps its id (its design file) when the file around it grows."""
    a = load_sweep(write(tmp_path, BASE + "[base]\nsmoke = true\n[grid]\nlr = [0.001]\n", "a.toml"))
    b = load_sweep(write(tmp_path, BASE.replace("[12345]", "[1, 2]") + "seeds = [5, 0]\n"
                         "[base]\nsmoke = true\n[grid]\nlr = [0.003, 0.001]\n", "b.toml"))
    assert a.runs[0].id in {r.id for r in b.runs}
    assert len({r.id for r in b.runs}) == 4


def test_options_mean_what_the_design_flags_mean():
    """design_inputs is what `design` uses: the same flags give the same plan and overrides."""
    args = build_parser().parse_args(["design", "oscillator", "--smoke", "--plan", "eq6", "--lr", "0.003",
                                      "--stages", "0:8:40,3:0", "--set", "kick=0.3"])
    cli = design_inputs(OscillatorProblem(), vars(args), KINDS["oscillator"].parse_sets(args.set))
    swept = opt.run_inputs("oscillator", {"smoke": True, "plan": "eq6", "lr": 0.003,
                                          "stages": [[0, 8, 40], [3, 0]], "kick": 0.3})
    assert cli.plan() == swept.plan() and cli.sets == swept.sets and cli.problem == swept.problem
    assert swept.plan().lr == 0.003 and swept.plan().iterations == 6 and swept.sets["target_scale"] == 1.0


def test_design_options_are_the_design_commands_flags():
    sub = build_parser()._subparsers._group_actions[0].choices["design"]
    flags = {a.dest for a in sub._actions if not isinstance(a, argparse._HelpAction)}
    assert set(DESIGN_OPTIONS) <= flags


def test_option_names_do_not_collide_with_result_columns():
    """A run's options and the table's own columns share one CSV header."""
    own = {"run", "variant", "seed", "status", *_TAIL}
    for kind in opt.BUILT_IN_KINDS:
        names = set(DESIGN_OPTIONS) | set(opt.scene_parameters(kind))
        assert not names & own
        assert not set(DESIGN_OPTIONS) & set(opt.scene_parameters(kind))


@pytest.mark.parametrize("text, where", [
    ('kind = "funnel"\neval_seeds = [1]\ncolour = 1\n', "colour: unknown key"),
    ('eval_seeds = [1]\n', "kind: missing"),
    ('kind = "pendulum"\neval_seeds = [1]\n', "kind: expected one of"),
    ('kind = "funnel"\n', "eval_seeds: missing"),
    ('kind = "funnel"\neval_seeds = [1, 1]\n', "eval_seeds: repeated"),
    ('kind = "funnel"\neval_seeds = [-1]\n', "eval_seeds[0]: expected an integer >= 0"),
    (BASE + 'seeds = [0, "1"]\n', "seeds[1]"),
    (BASE + 'eval_particles = 0\n', "eval_particles"),
    (BASE + '[base]\nlrr = 0.1\n', "base.lrr: unknown option"),
    (BASE + '[base]\nlr = "fast"\n', "base.lr: expected a float"),
    (BASE + '[base]\ngrid = 2.5\n', "base.grid: grid must be an int"),
    (BASE + '[base]\nsmoke = 1\n', "base.smoke: expected a bool"),
    (BASE + '[base]\nlr = true\n', "base.lr: expected a float, got true"),
    ('kind = "funnel"\neval_seeds = [true]\n', "eval_seeds[0]: expected an integer >= 0, got true"),
    (BASE + '[base]\nseed = 3\n', "base.seed: give the run seeds as the top-level list"),
    (BASE + '[grid]\nlr = 0.1\n', "grid.lr: expected a non-empty list"),
    (BASE + '[grid]\nlr = []\n', "grid.lr: expected a non-empty list"),
    (BASE + '[grid]\nlr = [0.1, "x"]\n', "grid.lr[1]: expected a float"),
    (BASE + '[grid]\nlr = [0.1, 0.1]\n', "the same run as"),
    (BASE + '[grid]\nlr = [0.1, -0.1]\n', "run lr = -0.1: lr must be"),
    (BASE + '[base]\nplan = "eq6"\n', "only the oscillator has named plans"),
    ('kind = "oscillator"\neval_seeds = [1]\n[base]\nplan = "best"\n', "plan 'best': expected one of"),
    (BASE + '[base]\noptimizer = "sgd"\n', "optimizer"),
    (BASE + '[base]\nstages = "0-25"\n', "--stages '0-25'"),
    (BASE + '[grid]\nlr = [0.1]\n[[variants]]\nlr = 0.2\n', "variants (v0).lr: also in [grid]"),
    (BASE + '[[variants]]\nname = "a"\n[[variants]]\nname = "a"\n', "variants[1].name"),
    (BASE + 'variants = 3\n', "variants: expected a list of tables"),
    (BASE + 'base = 3\n', "base: expected a table"),
    (BASE + '[base\n', "not valid TOML"),
])
def test_a_bad_file_gets_one_line_naming_the_key(tmp_path, text, where):
    path = write(tmp_path, text)
    with pytest.raises(SweepFileError) as exc:
        load_sweep(path)
    message = str(exc.value)
    assert message.startswith(f"{path}: ") and where in message, message
    assert "\n" not in message


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(SweepFileError, match="^sweep file .*nothing.toml does not exist$"):
        load_sweep(tmp_path / "nothing.toml")


def test_every_top_level_key_is_documented():
    text = (ROOT / "docs" / "sweeps.md").read_text()
    for key in TOP_LEVEL_KEYS:
        assert f"`{key}`" in text


@pytest.mark.parametrize("path", sorted(EXPERIMENTS.glob("*.toml")), ids=lambda p: p.name)
def test_the_teams_sweep_files_are_valid(path):
    sweep = load_sweep(path)
    assert sweep.runs and sweep.description


def test_importing_the_sweep_layer_imports_neither_dask_nor_the_cli():
    """The package works without the extra, and sits below the command line."""
    code = ("import sys, pes_ref.sweep, pes_ref.sweep.runner, pes_ref.sweep.cluster, pes_ref.sweep.task; "
            "bad = [m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed') "
            "or m.startswith('pes_ref.cli')]; print(bad)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_parse_sweep_takes_parsed_data():
    sweep = parse_sweep({"kind": "funnel", "eval_seeds": [3], "base": {"smoke": True}})
    assert len(sweep.runs) == 1 and sweep.runs[0].options == {"smoke": True} and sweep.axes == ()
