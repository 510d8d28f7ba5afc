"""Sweep files: a TOML file read into the list of runs it names.

A sweep file (read with `tomllib`)::

    description = "funnel: learning rate x seed"    # optional
    kind = "funnel"                                  # "funnel" or "oscillator"; or instead:
    # problem = "latch.toml"                         # a problem file (docs/problems.md), beside this file
    seeds = [0, 1]                                   # run seeds, one more axis (default [0])
    eval_seeds = [12345, 12346]                      # held-out seeds every run is evaluated on
    eval_particles = 100                             # optional: held-out particles (evaluate's default)

    [base]                 # options every run shares
    iterations = 60
    stages = [[0, 25]]

    [grid]                 # every combination of these values
    lr = [0.001, 0.002]

    [[variants]]           # and/or a list of named option sets
    name = "big_batch"
    particles = 128

An *option* is a design option (`pes_ref.synthesis.engine.runs.DESIGN_OPTIONS`, the flags
of ``python -m pes_ref design`` without the dashes, ``-`` as ``_``) or a scene parameter
of the kind (what ``--set NAME=VALUE`` sets; for a problem file, any of its keys by its
dotted name, quoted: ``"dynamics.dt" = 0.005``). The runs are every variant (or one run of
``[base]`` alone) times every grid point times every seed; a run's options are
``[base]``, then its variant's, then its grid point's. Every run is checked here, once:
a bad file raises one [`SweepFileError`][pes_ref.sweep.spec.SweepFileError] whose message names the file and the key.
"""
from __future__ import annotations

import hashlib
import itertools
import json
import os
from dataclasses import dataclass

from pes_ref.core.backends import check_backend
from pes_ref.core.runtime.keyfile import TYPES, Key, KeyFileError, KeyReader, parse_toml, read_text, show
from pes_ref.synthesis import DESIGN_OPTIONS, ProblemFileError, load_problem, problem_text
from pes_ref.sweep.options import BUILT_IN_KINDS, has_type, run_inputs, scene_parameters, type_name, typed_sets

__all__ = ["Sweep", "Run", "SweepFileError", "load_sweep", "parse_sweep", "TOP_LEVEL_KEYS"]

class SweepFileError(KeyFileError):
    """A sweep file that cannot be run; the message names the file and the key."""


@dataclass(frozen=True)
class Run:
    """One design run of a sweep: design, then evaluate on every held-out seed.

    ``id`` depends only on what the design depends on (kind, options, seed), so the
    same run keeps its id, and its design file, when the sweep file around it changes.
    """

    id: str
    kind: str
    variant: str
    options: dict
    seed: int

    def payload(self, sweep: "Sweep", design_file: str) -> dict:
        """The plain data a worker needs to do this run (see
        [`pes_ref.sweep.task.run_task`][pes_ref.sweep.task.run_task]);
        a problem file travels as its text, so a worker on another machine needs no file."""
        return {"id": self.id, "kind": self.kind, "options": self.options, "seed": self.seed,
                "eval_seeds": list(sweep.eval_seeds), "eval_particles": sweep.eval_particles,
                "design_file": design_file,
                "problem_text": None if sweep.problem is None else problem_text(sweep.problem),
                "problem_path": None if sweep.problem is None else sweep.problem.path}


@dataclass(frozen=True)
class Sweep:
    """A sweep file read and checked: its runs and what varies across them."""

    path: str
    description: str
    kind: str
    runs: tuple
    swept: tuple            #: option names whose value differs between runs ("variant" first if several)
    axes: tuple             #: what the file sweeps: "variant" (if several) and the grid's options of several values
    seeds: tuple
    eval_seeds: tuple
    eval_particles: int | None
    problem: object = None  #: the problem file's problem (kind "problem"), None for a built-in kind

    @property
    def name(self) -> str:
        """The file's stem (the default output folder's name)."""
        return os.path.splitext(os.path.basename(self.path))[0]


def _seeds(r, v, w, k) -> tuple:
    """A non-empty list of distinct integers >= 0."""
    if not isinstance(v, list) or not v:
        r.fail(w, f"expected a non-empty list of integers >= 0, got {show(v)}")
    for i, seed in enumerate(v):
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            r.fail(r.at(w, i), f"expected an integer >= 0, got {show(seed)}")
    if len(set(v)) != len(v):
        r.fail(w, f"repeated seeds in {show(v)}")
    return tuple(v)


class _Reader(KeyReader):
    error = SweepFileError
    noun = "a sweep file"
    types = {**TYPES, "seeds": _seeds}


#: The keys of a sweep file's top level: type, default (the module docstring has their meaning;
#: docs/sweeps.md documents each).
TOP_LEVEL_KEYS = {"description": Key("text", ""), "kind": Key("choice", None, choices=tuple(sorted(BUILT_IN_KINDS))),
                  "problem": Key("text", None), "seeds": Key("seeds", (0,)), "eval_seeds": Key("seeds", None),
                  "eval_particles": Key("count", None), "base": Key("table", {}), "grid": Key("table", {}),
                  "variants": Key("table_list", ())}


def load_sweep(path) -> Sweep:
    """Read and check the sweep file at ``path``.

    Raises
    ------
    SweepFileError
        For a missing or unreadable file, bad TOML, an unknown key, a value of the wrong
        type, or a run whose options the design refuses; one line naming the key.
    """
    path = os.fspath(path)
    return parse_sweep(parse_toml(read_text(path, SweepFileError, "sweep file"), path, SweepFileError), path)


def parse_sweep(data: dict, path: str = "<sweep>") -> Sweep:
    """Check the parsed TOML ``data`` of a sweep file and expand it into its runs."""
    r = _Reader(path)
    fail = r.fail
    top = r.table(data, "", TOP_LEVEL_KEYS)
    problem = None
    if top["problem"] is not None:
        if top["kind"] is not None:
            fail("kind", "give kind or problem, not both")
        problem = _problem(top["problem"], path, fail)
        kind = "problem"
    elif top["kind"] is None:
        fail("kind", "missing (kind = \"funnel\" or \"oscillator\", or problem = \"FILE.toml\")")
    else:
        kind = top["kind"]
    if top["eval_seeds"] is None:
        fail("eval_seeds", "missing (the held-out seeds every run is evaluated on, e.g. eval_seeds = [12345])")
    description, seeds, eval_seeds, eval_particles = (top[key] for key in
                                                      ("description", "seeds", "eval_seeds", "eval_particles"))

    base = _options(top["base"], "base", kind, fail)
    grid = top["grid"]
    for name, values in grid.items():
        if not isinstance(values, list) or not values:
            fail(f"grid.{name}", f"expected a non-empty list of values, got {show(values)}")
        for i, value in enumerate(values):
            _options({name: value}, f"grid.{name}[{i}]", kind, fail)
    variants = _variants(top["variants"], kind, fail)
    problem_id = None if problem is None else json.dumps(problem.data, sort_keys=True)
    for vname, options in variants:
        for name in options:
            if name in grid:
                fail(f"variants ({vname}).{name}", "also in [grid]; give each option in one of them")

    points = [dict(zip(grid, combo)) for combo in itertools.product(*grid.values())]
    runs, seen = [], {}
    for vname, voptions in variants or [("", {})]:
        for point in points:
            options = {**base, **voptions, **point}
            where = _where(vname, point)
            try:
                inputs = run_inputs(kind, options, problem)          # checks the problem with its sets
                inputs.plan()
                if options.get("backend") is not None:
                    check_backend(options["backend"])
            except (ValueError, TypeError) as exc:
                fail(where, " ".join(str(exc).split()))
            for seed in seeds:
                run = Run(_run_id(kind, options, seed, problem_id), kind, vname, options, seed)
                if run.id in seen:
                    fail(where, f"the same run as {seen[run.id]} (same options and seed {seed})")
                seen[run.id] = where
                runs.append(run)
    several = len(variants) > 1
    axes = (("variant",) if several else ()) + tuple(name for name, values in grid.items() if len(values) > 1)
    return Sweep(path, description, kind, tuple(runs), _swept(runs, several), axes, seeds, eval_seeds,
                 eval_particles, problem)


# --------------------------------------------------------------------------- pieces

def _problem(value, path: str, fail):
    """The problem file ``value`` names, relative to the sweep file's folder."""
    where = os.path.join(os.path.dirname(os.path.abspath(path)), value)
    try:
        return load_problem(where)
    except ProblemFileError as exc:
        fail("problem", str(exc))


def _options(table: dict, key: str, kind: str, fail) -> dict:
    """Check that every entry of ``table`` is a known option with a value of its type."""
    scene = scene_parameters(kind) if kind != "problem" else {}
    for name, value in table.items():
        where = key if key.endswith("]") else f"{key}.{name}"
        if name == "seed":
            fail(where, "give the run seeds as the top-level list seeds = [...]")
        if kind == "problem" and "." in name and name not in DESIGN_OPTIONS:
            continue                                 # a problem file's key, checked with the run
        if name in DESIGN_OPTIONS:
            want = DESIGN_OPTIONS[name]
            wants = want if isinstance(want, tuple) else (want,)
            if not any(has_type(value, w) for w in wants):
                fail(where, f"expected {type_name(want)}, got {show(value)}")
        elif name in scene:
            try:
                typed_sets({name: value}, kind)
            except ValueError as exc:
                fail(where, str(exc))
        elif kind == "problem":
            fail(where, f"unknown option; expected a design option ({', '.join(DESIGN_OPTIONS)}) or a key of "
                        "the problem file by its dotted name (\"dynamics.dt\" = 0.005)")
        else:
            fail(where, f"unknown option; expected a design option ({', '.join(DESIGN_OPTIONS)}) "
                        f"or a {kind} scene parameter ({', '.join(scene)})")
    return dict(table)


def _variants(value, kind, fail) -> list:
    out, names = [], set()
    for i, entry in enumerate(value):
        entry = dict(entry)
        name = entry.pop("name", f"v{i}")
        if not isinstance(name, str) or not name or name in names:
            fail(f"variants[{i}].name", f"expected a non-empty name of its own, got {show(name)}")
        names.add(name)
        out.append((name, _options(entry, f"variants ({name})", kind, fail)))
    return out


def _where(variant: str, point: dict) -> str:
    parts = ([f"variant {variant}"] if variant else []) + [f"{k} = {show(v)}" for k, v in point.items()]
    return "run " + (", ".join(parts) if parts else "[base]")


def _run_id(kind: str, options: dict, seed: int, problem: str | None = None) -> str:
    """A stable id: a readable stem and a hash of everything the design depends on (with a
    problem file's text, for kind ``"problem"``)."""
    state = {"kind": kind, "options": options, "seed": seed}
    if problem is not None:
        state["problem"] = problem
    text = json.dumps(state, sort_keys=True)

    digest = hashlib.sha1(text.encode()).hexdigest()[:10]
    return f"{kind}-s{seed}-{digest}"


def _swept(runs, several_variants: bool) -> tuple:
    """Option names whose value differs between runs (``variant`` first when there are several)."""
    names = sorted({k for r in runs for k in r.options})
    varying = [k for k in names
               if len({json.dumps(r.options.get(k), sort_keys=True) for r in runs}) > 1]
    return (("variant",) if several_variants else ()) + tuple(varying)
