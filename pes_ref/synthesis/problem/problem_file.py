"""Problem files: a TOML file (read with `tomllib`) that states a design problem completely.

Every key, its unit and default is documented in ``docs/problems.md``; this module is the
one place that reads them (the key tables, [`.file_keys`][pes_ref.synthesis.problem.file_keys] for their types). A file is
checked whole before anything runs: an unknown key, a missing one or a bad value raises
one [`ProblemFileError`][pes_ref.synthesis.problem.file_keys.ProblemFileError] whose message names the file and
the key (``latch.toml: objective[2].weight: expected a number >= 0, got -1``). The format is
versioned by the top-level key ``format`` (`FORMAT`); a file of another version is refused.

The same tables, as a dict, state a problem in code
([`parse_problem`][pes_ref.synthesis.problem.problem_file.parse_problem]), where a ``custom`` term's
``object`` may be the object itself. [`with_sets`][pes_ref.synthesis.problem.problem_file.with_sets]
changes keys of a problem by their dotted names (``--set dynamics.dt=0.005``);
[`problem_text`][pes_ref.synthesis.problem.problem_file.problem_text] is the TOML text a design file
embeds (the file's own text when nothing was changed).
"""
from __future__ import annotations

import dataclasses
import functools

import math
import os
import sys
import tomllib
from importlib import resources

import numpy as np

from pes_ref.core import budget
from pes_ref.core.checks import InputError

from pes_ref.core.interpolations import INTERPOLATIONS
from pes_ref.core.surface import spacing as grid_spacing
from pes_ref.core.stability import check_stable
from pes_ref.core.steppers import INTEGRATORS, MODES
from pes_ref.core.terms import Spring, Walls
from pes_ref.synthesis.problem.design_problem import FORCES, DesignProblem, Force, Scenario, StartGroup, Starts
from pes_ref.core.runtime.keyfile import parse_toml, read_text, show
from pes_ref.synthesis.problem.file_keys import Key, ProblemFileError, Reader
from pes_ref.synthesis.problem.objective_terms import OBJECTIVE_TERMS, CustomTerm, Domain, TermSum, is_grid_term
from pes_ref.synthesis.common.plans import Plan, default_plan
from pes_ref.synthesis.problem.problem_contact import Contact
from pes_ref.synthesis.problem.failing import ShareCeiling, has_fail_cost
from pes_ref.synthesis.problem.success import SUCCESS_TESTS, GroupTest, ShareCriterion, outside_domain
from pes_ref.synthesis.problem.surrogates import DEFAULT_MARGIN, derived_terms, has_cost

__all__ = ["FORMAT", "load_problem", "parse_problem", "problem_from_text", "problem_text", "with_sets",
           "parse_set", "shipped_problem", "at_step", "plan_for", "default_stages", "SHIPPED_PROBLEMS", "ProblemFileError",
           "SECTIONS"]

#: The problem-file format this module reads.
FORMAT = 1
#: The problem files shipped in the package (``pes_ref/synthesis/data/NAME.toml``).
SHIPPED_PROBLEMS = ("funnel", "latch", "latch_contact")

TOP_KEYS = {"format": Key("count"), "name": Key("text", None), "description": Key("text", "")}
#: The sections of a problem file, after the top-level keys.
SECTIONS = ("surface", "dynamics", "starts", "forces", "objective", "evaluate", "train")
SURFACE_KEYS = {
    "lower": Key("point", unit="length"), "upper": Key("point", unit="length"),
    "periodic": Key("bool_pair", (False, False)), "shape": Key("grid_pair", unit="nodes"),
    "interpolation": Key("choice", "bilinear", choices=tuple(INTERPOLATIONS)),
}
#: ``[surface.contact]``: eq. (1) of blocked space, and a design made of it (``docs/realize.md``).
CONTACT_KEYS = {
    "v": Key("positive", unit="energy length^2"), "r_c": Key("positive", unit="length"),
    "r_min": Key("positive", None, unit="length"), "realizable": Key("bool", False),
    "blocked": Key("shapes", None, unit="length"), "clearance": Key("nonneg", None, unit="length"),
    "restitution": Key("nonneg", None),
}
HOLD_KEYS = {"lower": Key("point", unit="length"), "upper": Key("point", unit="length")}
DYNAMICS_KEYS = {
    "mode": Key("choice", "dynamic", choices=MODES), "integrator": Key("choice", "verlet", choices=INTEGRATORS),
    "dt": Key("positive", unit="time"), "duration": Key("positive", None, unit="time"),
    "n_steps": Key("count", None, unit="steps"), "mass": Key("positive_or_pair", 1.0, unit="mass"),
    "damping": Key("nonneg_or_pair", 0.0, unit="force time/length"),
    "mobility": Key("positive_or_pair", None, unit="length/(force time)"),
}
SPRING_KEYS = {"k": Key("nonneg_or_pair", unit="force/length"), "center": Key("point", (0.0, 0.0), unit="length")}
WALL_KEYS = {"k": Key("positive", unit="force/length"), "margin": Key("nonneg", unit="length"),
             "edges": Key("edges", None)}
STARTS_KEYS = {"box": Key("box", None, unit="length"), "points": Key("points", None, unit="length"),
               "velocity": Key("velocity", ((0.0, 0.0), (0.0, 0.0)), unit="length/time")}
#: ``[[starts.group]]``: a group's name and share of a batch beside the starts' own keys.
GROUP_KEYS = {"name": Key("text"), "share": Key("positive", 1.0)}
#: Keys every ``[[forces]]`` entry may have beside its kind's own (`pes_ref.synthesis.problem.design_problem.FORCES`).
FORCE_KEYS = {"kind": Key("choice", choices=tuple(FORCES)), "name": Key("text", ""),
              "from": Key("nonneg", None, unit="time"), "to": Key("positive", None, unit="time")}
#: Keys every ``[[objective]]`` term and ``[[evaluate.success]]`` test may have beside its kind's own.
TERM_KEYS = {"kind": Key("choice", choices=tuple(OBJECTIVE_TERMS)), "name": Key("text", None)}
TEST_KEYS = {"kind": Key("choice", choices=tuple(SUCCESS_TESTS)), "name": Key("text", None),
             "group": Key("text", None)}
EVALUATE_KEYS = {"particles": Key("count", 200, unit="particles"),
                 "margin": Key("fraction", DEFAULT_MARGIN)}
#: ``[[evaluate.share]]``: a population criterion, the share of particles passing a test in a range.
SHARE_KEYS = {"name": Key("text", "share"), "test": Key("table"), "min": Key("share", 0.0), "max": Key("share", 1.0)}
SCENARIO_KEYS = {"name": Key("text"), "duration": Key("positive", None, unit="time")}
TRAIN_KEYS = {
    "iterations": Key("count", 300), "particles": Key("count", 64, unit="particles"),
    "optimizer": Key("choice", "rmsprop", choices=("rmsprop", "adam")), "lr": Key("positive", 0.002),
    "lr_final": Key("positive", None), "decay_iterations": Key("count", None), "clip": Key("positive", None),
    "stages": Key("stages", None), "scale_lr_by_grid": Key("bool", True),
    "init_scale": Key("nonneg", 1e-3, unit="energy"),
    "validate_every": Key("count", None), "validation_particles": Key("count", 200, unit="particles"),
    "target": Key("positive", None),
    "smoothing": Key("nonneg", 0.0, unit="energy"), "smoothing_draws": Key("count", 4),
    "starts": Key("count", 1), "screen": Key("count", None, unit="iterations"),
}
#: Without ``train.stages``: a coarse grid of this many nodes along axis 0 (if the final grid is
#: finer) for the first `COARSE_SHARE` of the iterations, then the final grid.
COARSE_GRID = 25
COARSE_SHARE = 0.8
#: A ``Scene`` argument named in a refusal, and the problem-file key that sets it.
_SCENE_KEYS = {"dt": "dynamics.dt", "n_steps": "dynamics", "mass": "dynamics.mass", "damping": "dynamics.damping",
               "mobility": "dynamics.mobility", "walls": "dynamics.walls", "wall_margin": "dynamics.walls.margin",
               "spring": "dynamics.spring", "integrator": "dynamics.integrator", "values": "surface.shape"}


# =========================================================================== reading

def load_problem(path) -> DesignProblem:
    """Read and check the problem file at ``path``.

    Raises
    ------
    ProblemFileError
        For a missing or unreadable file, bad TOML, or any bad key or value: one line naming the key.
    """
    path = os.fspath(path)
    return problem_from_text(read_text(path, ProblemFileError, "problem file"), path)


def problem_from_text(text: str, path: str = "<problem>") -> DesignProblem:
    """The problem of a problem file's ``text`` (``path`` names it in messages)."""
    return parse_problem(parse_toml(text, path, ProblemFileError), path, text)


def shipped_problem(name: str) -> str:
    """The path of the problem file ``name`` (`SHIPPED_PROBLEMS`) shipped with the package."""
    if name not in SHIPPED_PROBLEMS:
        raise ValueError(f"no shipped problem {name!r}; expected one of {', '.join(SHIPPED_PROBLEMS)}")
    return str(resources.files("pes_ref.synthesis").joinpath("data", f"{name}.toml"))


def _tables(value):
    """A copy of the tables and lists of problem data; the values in them (numbers, text, a
    ``custom`` term's object built in code) are shared, not copied."""
    if isinstance(value, dict):
        return {k: _tables(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_tables(v) for v in value]
    return value


def _plain(value):
    """``value`` with tuples as lists and NumPy scalars as Python's: data that TOML writes and reads back equal."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def parse_problem(data: dict, path: str = "<problem>", text: str | None = None) -> DesignProblem:
    """Check the tables ``data`` of a problem (a parsed file, or a dict built in code) and build it.

    ``text`` is the file's text, kept for design files (None: written from ``data`` when needed).
    """
    r = Reader(path)
    data = _plain(data)
    top = r.table(data, "", TOP_KEYS, also=SECTIONS)
    if top["format"] != FORMAT:
        r.fail("format", f"this pes_ref reads problem files of format {FORMAT}, got {top['format']}")
    name = top["name"] or (os.path.splitext(os.path.basename(path))[0] if not path.startswith("<") else "problem")

    surface = r.table(_section(r, data, "surface"), "surface", SURFACE_KEYS, also=("hold", "contact"))
    r.ordered(surface["lower"], surface["upper"], "surface", strict=True)
    holds = _list(r, _section(r, data, "surface").get("hold", []), "surface.hold")
    holds = tuple(r.box(h, f"surface.hold[{i}]") for i, h in enumerate(holds))
    domain = Domain(surface["lower"], surface["upper"], surface["periodic"])
    contact = _contact(r, _section(r, data, "surface").get("contact"), surface)

    scene_keys, n_steps = _dynamics(r, _section(r, data, "dynamics"), domain)
    duration = n_steps * scene_keys["dt"]
    starts = _starts(r, _section(r, data, "starts"), domain)
    forces = _forces(r, data.get("forces", []), "forces", duration)

    evaluate = _section(r, data, "evaluate")
    ev = r.table(evaluate, "evaluate", EVALUATE_KEYS, also=("success", "scenario", "share"))
    tests = _tests(r, evaluate.get("success"), "evaluate.success", domain, duration, scene_keys["dt"], starts)
    shares = []
    for i, entry in enumerate(_list(r, evaluate.get("share", []), "evaluate.share")):
        at = f"evaluate.share[{i}]"
        keys = r.table(entry, at, SHARE_KEYS)
        if not keys["max"] >= keys["min"]:
            r.fail(f"{at}.max", f"expected max >= min, got min {keys['min']:g}, max {keys['max']:g}")
        test = _test(r, keys["test"], f"{at}.test", domain, duration, scene_keys["dt"], starts)[1]
        shares.append((keys["name"], ShareCriterion(test, keys["min"], keys["max"])))
    shares = tuple(zip(_unique([n for n, _ in shares]), (c for _, c in shares)))

    entries = _list(r, data["objective"], "objective", required=True) if "objective" in data else []
    terms, names = [], []
    for i, entry in enumerate(entries):
        where = f"objective[{i}]"
        kind = _kind(r, entry, where, TERM_KEYS)
        cls = OBJECTIVE_TERMS[kind]
        keys = r.table(entry, where, cls.KEYS, also=TERM_KEYS)
        _check_times(r, keys, where, duration, scene_keys["dt"])
        _check_box(r, keys, where)
        term = _build(r, where, cls.from_keys, keys, domain, duration)
        names.append(r.value(entry["name"], f"{where}.name", TERM_KEYS["name"]) if "name" in entry else kind)
        terms.append(term)
    names = _unique(names)
    grid_terms = [t for t in terms if is_grid_term(t)]
    state = [(n, _custom_named(t, n, i, entries[i]["object"]) if isinstance(t, CustomTerm) else t)
             for i, (n, t) in enumerate(zip(names, terms)) if not is_grid_term(t)]
    if "objective" not in data:           # designed on what success means: each test's surrogate
        _refuse_costless(r, tests, "evaluate.success")
        for i, (n, c) in enumerate(shares):
            if c.high < 1.0 and not has_fail_cost(c.test):
                r.fail(f"evaluate.share[{i}].max", f"share {n!r}: a max below 1 is charged by its test's surrogate "
                                                   f"of failing, and a {c.test.KIND} test has none; give "
                                                   f"[[objective]] terms, or max = 1")
        state = derived_terms(tests, ev["margin"]) + derived_terms(
            [(f"share_{n}", c) for n, c in shares if c.low > 0.0], ev["margin"]) + derived_terms(
            [(f"share_{n}_max", ShareCeiling(c.test, c.high)) for n, c in shares if c.high < 1.0], ev["margin"])
    scenarios = []
    for i, sc in enumerate(_list(r, evaluate.get("scenario", []), "evaluate.scenario")):
        where = f"evaluate.scenario[{i}]"
        keys = r.table(sc, where, SCENARIO_KEYS, also=("forces", "success"))
        sc_steps = n_steps if keys["duration"] is None else _steps(keys["duration"], scene_keys["dt"])
        sc_duration = sc_steps * scene_keys["dt"]
        sc_forces = forces if "forces" not in sc else _forces(r, sc["forces"], f"{where}.forces", sc_duration)
        sc_tests = _tests(r, sc.get("success"), f"{where}.success", domain, sc_duration, scene_keys["dt"], starts)
        charged = None
        if "objective" not in data:       # designed on its tests: the scenario's are charged too
            _refuse_costless(r, sc_tests, f"{where}.success")
            charged = TermSum([t for _, t in derived_terms(sc_tests, ev["margin"])])
        scenarios.append(Scenario(keys["name"], sc_steps, sc_forces, sc_tests, charged))
    if len({s.name for s in scenarios}) != len(scenarios):
        r.fail("evaluate.scenario", f"two scenarios have the same name: {[s.name for s in scenarios]}")

    warnings = [f"{at} ({name}): its region {[[round(v, 9) for v in c] for c in region]} lies wholly outside "
                f"the domain [{_plain(domain.lower)}, {_plain(domain.upper)}], where the surface is not designed: "
                f"no particle is brought there"
                for at, name, test in _located(tests, "evaluate.success", scenarios)
                if (region := outside_domain(test, domain)) is not None]
    plan, init_scale = _train(r, data.get("train"), surface["shape"], _coarse(contact))
    problem = DesignProblem(
        data=data, path=path, text=text, name=name, description=top["description"], lower=surface["lower"],
        upper=surface["upper"], periodic=surface["periodic"], grid_shape=surface["shape"],
        interpolation=surface["interpolation"], holds=holds, scene_keys=scene_keys, n_steps=n_steps, starts=starts,
        forces=forces, terms=[t for _, t in state], term_names=[n for n, _ in state] + [
            n for n, t in zip(names, terms) if is_grid_term(t)],
        grid_terms=grid_terms, tests=tests, shares=shares, scenarios=tuple(scenarios), eval_particles=ev["particles"], plan=plan,
        init_scale=init_scale, contact=contact, warnings=tuple(warnings))
    _check_scene(r, problem)
    return problem


def _refuse_costless(r: Reader, tests, where: str) -> None:
    """A problem designed on its tests needs each test's surrogate: a custom test without ``cost`` is refused."""
    for i, (test_name, test) in enumerate(tests):
        if not has_cost(test):
            r.fail(f"{where}[{i}].object", f"test {test_name!r} has no cost(x, v, t, margin) for the objective "
                                           f"derived from the tests; give it one, or give [[objective]] terms")


def _located(tests, where: str, scenarios) -> list:
    """``(key, name, test)`` of every success test, the scenarios' too, by its place in the file."""
    out = [(f"{where}[{i}]", name, test) for i, (name, test) in enumerate(tests)]
    for j, sc in enumerate(scenarios):
        out += [(f"evaluate.scenario[{j}].success[{i}]", name, test) for i, (name, test) in enumerate(sc.tests)]
    return out


def _custom_named(term: CustomTerm, name: str, i: int, obj) -> CustomTerm:
    """A custom term with its name and its label, ``objective[1] (custom 'spread', mymod:SPREAD)``."""
    spec = obj if isinstance(obj, str) else f"a {type(obj).__name__}"
    return dataclasses.replace(term, name=name, label=f"objective[{i}] (custom {name!r}, {spec})")


def _contact(r: Reader, table, surface: dict) -> Contact | None:
    """``[surface.contact]`` (None: the file has none)."""
    if table is None:
        return None
    keys = r.table(table, "surface.contact", CONTACT_KEYS)
    r_min = keys["r_min"]
    if r_min is None:
        from pes_ref.devices.cspace import default_r_min      # the device files' rule, one home
        r_min = default_r_min(grid_spacing(np.asarray(surface["lower"], dtype=np.float64),
                                           np.asarray(surface["upper"], dtype=np.float64), surface["shape"],
                                           np.asarray(surface["periodic"])))
        if not r_min < keys["r_c"]:
            r.fail("surface.contact.r_c", f"expected r_c above r_min's default, half the finer grid spacing "
                                          f"({r_min:g}), got {keys['r_c']:g}")
    elif not r_min < keys["r_c"]:
        r.fail("surface.contact.r_min", f"expected r_min < r_c = {keys['r_c']:g}, got {r_min:g}")
    if not keys["realizable"] and keys["blocked"] is not None:
        r.fail("surface.contact.blocked", "is the starting shape of a realizable design; set "
                                          "surface.contact.realizable = true, or leave blocked out")
    if keys["restitution"] is not None and keys["restitution"] > 1.0:
        r.fail("surface.contact.restitution", f"expected a number in [0, 1], got {show(keys['restitution'])}")
    return Contact(keys["v"], keys["r_c"], float(r_min), keys["realizable"], keys["blocked"] or (),
                   keys["clearance"], keys["restitution"])


def _section(r: Reader, data: dict, name: str) -> dict:
    if name not in data:
        r.fail(name, f"missing (a problem file has [{name}]; see docs/problems.md)")
    if not isinstance(data[name], dict):
        r.fail(name, f"expected a table [{name}], got {show(data[name])}")
    return data[name]


def _list(r: Reader, value, where: str, required: bool = False) -> list:
    if value is None and required:
        r.fail(where, f"missing (at least one [[{where}]] entry)")
    if not isinstance(value, list) or (required and not value):
        r.fail(where, f"expected a list of tables ([[{where}]]), got {show(value)}")
    for i, entry in enumerate(value):
        if not isinstance(entry, dict):
            r.fail(f"{where}[{i}]", f"expected a table, got {show(entry)}")
    return value


def _kind(r: Reader, entry: dict, where: str, keys: dict) -> str:
    if "kind" not in entry:
        r.fail(f"{where}.kind", f"missing; one of {', '.join(keys['kind'].choices)}")
    return r.value(entry["kind"], f"{where}.kind", keys["kind"])


def _unique(names: list) -> tuple:
    """Names with a repeated one numbered by its place (``stay_in_1``, ``stay_in_3``)."""
    return tuple(n if names.count(n) == 1 else f"{n}_{i}" for i, n in enumerate(names))


def _build(r: Reader, where: str, make, *args):
    """``make(*args)``, with a library refusal reworded to name the key."""
    try:
        return make(*args)
    except (ValueError, TypeError) as exc:
        r.fail(where, " ".join(str(exc).split()))


def _steps(duration: float, dt: float) -> int:
    """Steps that cover ``duration``: ``ceil(duration / dt)``, to within rounding."""
    return max(1, math.ceil(duration / dt - 1e-9))


def _check_times(r: Reader, keys: dict, where: str, duration: float, dt: float) -> None:
    for name in ("time", "from"):
        if keys.get(name) is not None and keys[name] > duration + 0.5 * dt:
            r.fail(f"{where}.{name}", f"{keys[name]:g} is after the end of the run ({duration:g}, dynamics)")
    if keys.get("from") is not None and keys.get("to") is not None and not keys["to"] >= keys["from"]:
        r.fail(f"{where}.to", f"expected to >= from, got from {keys['from']:g}, to {keys['to']:g}")


def _check_box(r: Reader, keys: dict, where: str) -> None:
    """An entry with corners ``lower`` and ``upper`` (``stay_in``, ``per_particle``) states a box: upper >= lower."""
    if "lower" in keys and "upper" in keys:
        r.ordered(keys["lower"], keys["upper"], where)


def _dynamics(r: Reader, table: dict, domain: Domain):
    d = r.table(table, "dynamics", DYNAMICS_KEYS, also=("spring", "walls"))
    if (d["duration"] is None) == (d["n_steps"] is None):
        r.fail("dynamics.duration", "give exactly one of duration and n_steps")
    n_steps = d["n_steps"] if d["duration"] is None else _steps(d["duration"], d["dt"])
    quasistatic = d["mode"] == "quasistatic"
    if quasistatic and d["mobility"] is None:
        r.fail("dynamics.mobility", "missing (quasistatic mode moves a particle by mobility times the force)")
    if not quasistatic and d["mobility"] is not None:
        r.fail("dynamics.mobility", "only for mode = 'quasistatic'")
    keys = {"dt": d["dt"], "mode": d["mode"], "integrator": d["integrator"], "mass": d["mass"],
            "damping": d["damping"] if any(d["damping"]) else None, "mobility": d["mobility"]}
    if "spring" in table:
        s = r.table(table["spring"], "dynamics.spring", SPRING_KEYS)
        keys["spring"] = _build(r, "dynamics.spring", Spring, s["k"], s["center"])
    if "walls" in table:
        w = r.table(table["walls"], "dynamics.walls", WALL_KEYS)
        edges = w["edges"] if w["edges"] is not None else tuple((not p, not p) for p in domain.periodic)
        keys["walls"] = _build(r, "dynamics.walls", Walls, w["k"], w["margin"], edges)
    return keys, n_steps


def _starts(r: Reader, table: dict, domain: Domain, where: str = "starts", groups: bool = True) -> Starts:
    s = r.table(table, where, STARTS_KEYS, also=("group",) if groups else ())
    if groups and "group" in table:
        if s["box"] is not None or s["points"] is not None:
            r.fail(f"{where}.group", "give either start groups or the starts' box or points, not both")
        if "velocity" in table:
            r.fail(f"{where}.velocity", f"{_plain(table['velocity'])} beside start groups is given to no particle; "
                                        f"give each [[starts.group]] its own velocity")
        out = []
        for i, entry in enumerate(_list(r, table["group"], f"{where}.group", required=True)):
            at = f"{where}.group[{i}]"
            keys = r.table(entry, at, GROUP_KEYS, also=tuple(STARTS_KEYS))
            out.append(StartGroup(keys["name"], keys["share"], _starts(
                r, {k: v for k, v in entry.items() if k not in GROUP_KEYS}, domain, at, False)))
        if len({g.name for g in out}) != len(out):
            r.fail(f"{where}.group", f"two groups have the same name: {[g.name for g in out]}")
        return Starts(None, None, s["velocity"], tuple(out))
    if (s["box"] is None) == (s["points"] is None):
        r.fail(f"{where}.box", "give exactly one of box and points" + (" (or start groups)" if groups else ""))
    corners = (s["box"] if s["box"] is not None else s["points"])
    key = "box" if s["box"] is not None else "points"
    for point in corners:
        if not _in_domain(point, domain):
            r.fail(f"{where}.{key}", f"{_plain(point)} lies outside the domain [{_plain(domain.lower)}, "
                                     f"{_plain(domain.upper)}]: particles start inside it")
    return Starts(s["box"], s["points"], s["velocity"])


def _in_domain(point, domain: Domain) -> bool:
    """Whether ``point`` lies in the domain (faces included) on its non-periodic axes."""
    return all(p or lo <= q <= hi for q, lo, hi, p in zip(point, domain.lower, domain.upper, domain.periodic))


def _forces(r: Reader, value, where: str, duration: float) -> tuple:
    out = []
    for i, entry in enumerate(_list(r, value, where)):
        at = f"{where}[{i}]"
        kind = _kind(r, entry, at, FORCE_KEYS)
        own = FORCES[kind][0]
        common = r.table({k: v for k, v in entry.items() if k not in own}, at, FORCE_KEYS, also=own)
        keys = r.table({k: v for k, v in entry.items() if k not in FORCE_KEYS}, at, own, also=FORCE_KEYS)
        _check_times(r, common, at, duration, 0.0)
        _check_box(r, keys, at)
        if common["to"] is not None and not common["to"] > (common["from"] or 0.0):
            r.fail(f"{at}.to", f"expected to > from, got from {common['from'] or 0.0:g}, to {common['to']:g}")
        out.append(Force(kind, keys, common["name"], common["from"], common["to"]))
    return tuple(out)


def _tests(r: Reader, value, where: str, domain: Domain, duration: float, dt: float, starts: Starts,
           key: str = "success") -> tuple:
    """The tests ``(name, test)`` of a list of test tables; a test with ``group`` judges that start
    group's particles only ([`pes_ref.synthesis.problem.success.GroupTest`][pes_ref.synthesis.problem.success.GroupTest])."""
    entries = _list(r, value, where, required=True)
    out = [_test(r, entry, f"{where}[{i}]", domain, duration, dt, starts) for i, entry in enumerate(entries)]
    return tuple(zip(_unique([n for n, _ in out]), (t for _, t in out)))


def _test(r: Reader, entry: dict, at: str, domain: Domain, duration: float, dt: float, starts: Starts) -> tuple:
    """One test table at ``at``: ``(name, test)``."""
    groups = [g.name for g in starts.groups]
    kind = _kind(r, entry, at, TEST_KEYS)
    cls = SUCCESS_TESTS[kind]
    keys = r.table(entry, at, cls.KEYS, also=TEST_KEYS)
    common = r.table({k: v for k, v in entry.items() if k in TEST_KEYS}, at, TEST_KEYS)
    _check_times(r, keys, at, duration, dt)
    _check_box(r, keys, at)
    children = getattr(cls, "CHILDREN", None)
    if children is not None:        # tests made of tests (any_of): each read as a test of this list
        keys[children] = [t for _, t in _tests(r, keys[children], f"{at}.{children}", domain, duration, dt,
                                               starts)]
    test = _build(r, at, cls.from_keys, keys, domain, duration)
    if hasattr(test, "label"):          # a custom test: named by its place when its object fails
        obj = entry["object"]
        spec = obj if isinstance(obj, str) else f"a {type(obj).__name__}"
        test = dataclasses.replace(test, label=f"{at} (custom {common['name'] or kind!r}, {spec})")
    if common["group"] is not None:
        if common["group"] not in groups:
            r.fail(f"{at}.group", f"no start group {common['group']!r}; the groups ([[starts.group]]) are "
                                  f"{', '.join(repr(g) for g in groups) or 'none'}")
        test = GroupTest(test, common["group"], functools.partial(starts.members, groups.index(common["group"])))
    return common["name"] or kind, test


def _train(r: Reader, table, shape, coarse: bool) -> tuple:
    """The plan and initial grid's scale: ``[train]``'s, or without the table the default plan
    ([`pes_ref.synthesis.common.plans.default_plan`][pes_ref.synthesis.common.plans.default_plan];
    ``coarse``: it may start on coarse grids, False for a design that starts from drawn shapes) and
    ``init_scale``."""
    if table is None:
        return default_plan(shape, coarse), TRAIN_KEYS["init_scale"].default
    t = r.table(table, "train", TRAIN_KEYS)
    its = t["iterations"]
    stages = t["stages"] if t["stages"] is not None else default_stages(shape, its)
    lr_final = t["lr"] if t["lr_final"] is None else t["lr_final"]
    decay = its if t["decay_iterations"] is None else t["decay_iterations"]
    screen = t["screen"] if t["screen"] is not None else stages[-1][0] if t["starts"] > 1 else 0
    if screen > its:
        r.fail("train.screen", f"expected at most train.iterations ({its}), got {screen}")
    try:
        plan = Plan(iterations=its, optimizer=t["optimizer"], lr=t["lr"], lr_final=lr_final, decay_iterations=decay,
                    clip=t["clip"], stages=stages, n_particles=t["particles"], scale_lr_by_grid=t["scale_lr_by_grid"],
                    validate_every=t["validate_every"] or 0, validation_particles=t["validation_particles"],
                    target=t["target"], smoothing=t["smoothing"], smoothing_draws=t["smoothing_draws"],
                    starts=t["starts"], screen=screen)
    except (ValueError, TypeError) as exc:
        r.fail(f"train.{getattr(exc, 'key', None) or 'stages'}", " ".join(str(exc).split()))
    return plan, t["init_scale"]


def default_stages(shape, iterations: int) -> tuple:
    """The stages of a file without ``train.stages``, for a run of ``iterations``: a grid of
    `COARSE_GRID` nodes along axis 0 (if ``shape`` is finer) for `COARSE_SHARE` of
    them, then the final grid."""
    coarse = min(COARSE_GRID, shape[0])
    return ((0, 0),) if coarse == shape[0] else ((0, coarse), (max(1, int(COARSE_SHARE * iterations)), 0))


def plan_for(problem: DesignProblem, iterations: int | None = None) -> Plan:
    """The plan of ``problem``'s ``[train]`` for a run of ``iterations`` (None: the file's own
    count): a file without ``train.stages`` has the default stages of that count, whether it comes
    from the file or from the command line; a file without ``[train]``, the default plan's."""
    if iterations is None or "stages" in problem.data.get("train", {}):
        return problem.plan
    if "train" not in problem.data:       # the default plan's stages and screen for that count
        plan = default_plan(problem.grid_shape, _coarse(problem.contact), iterations)
        return dataclasses.replace(problem.plan, stages=plan.stages, screen=plan.screen)
    stages = default_stages(problem.grid_shape, iterations)
    if problem.plan.starts > 1 and "screen" not in problem.data["train"]:      # screened to the last stage
        return dataclasses.replace(problem.plan, stages=stages, screen=stages[-1][0])
    return dataclasses.replace(problem.plan, stages=stages)


def _coarse(contact) -> bool:
    """Whether the default plan may start on coarse grids: not for a design from drawn shapes (a realizable contact's)."""
    return contact is None or not contact.realizable


def _check_scene(r: Reader, problem: DesignProblem) -> None:
    """The grid's memory, the scene's own checks and the stability rule, on the final grid
    with flat values."""
    try:
        budget.check_grid_memory(problem.grid_shape, "shape", length=f"shape = {list(problem.grid_shape)}")
    except budget.RunTooLargeError as exc:
        r.fail("surface.shape", " ".join(str(exc).split()))
    try:
        check_stable(problem.scene(problem.flat_values()))
    except InputError as exc:
        r.fail(_SCENE_KEYS.get(exc.key, "dynamics"), " ".join(str(exc).split()))


# =========================================================================== changing and writing

def parse_set(text: str):
    """``NAME=VALUE`` (``--set``) to ``(dotted name, value)``; VALUE is read as a TOML value
    (``0.005``, ``[1, 2]``, ``true``, ``"text"``), or taken as text when it is not one."""
    name, sep, value = text.partition("=")
    if not sep or not name:
        raise ValueError(f"--set {text!r}: expected NAME=VALUE with NAME a dotted key of the problem file, "
                         f"e.g. dynamics.dt=0.005")
    try:
        return name.strip(), tomllib.loads(f"v = {value}")["v"]
    except tomllib.TOMLDecodeError:
        return name.strip(), value


def with_sets(problem: DesignProblem, sets: dict) -> DesignProblem:
    """``problem`` with the keys named by dotted names changed (``{"dynamics.dt": 0.005,
    "objective.1.weight": 2.0}``; a number picks an entry of a list of tables), checked again."""
    if not sets:
        return problem
    data = _tables(problem.data)
    for dotted, value in sets.items():
        parts = dotted.split(".")
        node = data
        for i, part in enumerate(parts[:-1]):
            here = ".".join(parts[:i + 1])
            if isinstance(node, list):
                if not (part.isdigit() and int(part) < len(node)):
                    raise ProblemFileError(f"{problem.path}: {dotted}: {'.'.join(parts[:i])} has entries 0 to "
                                           f"{len(node) - 1}")
                node = node[int(part)]
            else:
                node = node.setdefault(part, {})
            if not isinstance(node, (dict, list)):
                raise ProblemFileError(f"{problem.path}: {dotted}: {here} is a value, not a table")
        if not isinstance(node, dict):
            raise ProblemFileError(f"{problem.path}: {dotted}: expected a key of a table, not an entry of a list")
        node[parts[-1]] = value
    return parse_problem(data, problem.path)


def at_step(problem: DesignProblem, dt: float) -> DesignProblem:
    """``problem`` run at step ``dt``: the same durations (a file's ``n_steps`` raised to cover its
    duration: ``ceil(n_steps dt0 / dt)``) and the noise's per-step std times ``sqrt(dt0 / dt)``
    (the same diffusion per unit time), checked again."""
    data = _tables(problem.data)
    dt0 = problem.dt
    dynamics = data["dynamics"]
    dynamics["dt"] = float(dt)
    if "n_steps" in dynamics:
        dynamics["n_steps"] = _steps(dynamics["n_steps"] * dt0, dt)
    scale = math.sqrt(dt0 / dt)
    schedules = [data.get("forces", [])] + [sc.get("forces", []) for sc in data.get("evaluate", {}).get("scenario", [])]
    for force in (f for schedule in schedules for f in schedule if f.get("kind") == "noise"):
        std = force["std"]
        force["std"] = [x * scale for x in std] if isinstance(std, list) else std * scale
    return parse_problem(data, problem.path)


def _object_name(obj, where: str) -> str:
    """``"module:name"`` of an object built in code, if it can be imported back."""
    module = getattr(obj, "__module__", None) or type(obj).__module__
    found = [k for k, v in vars(sys.modules.get(module, object())).items() if v is obj]
    if module == "__main__" or not found:
        raise ProblemFileError(f"{where}.object: an object built in code ({show(obj)}) cannot be written into a "
                               f"design file; define it at the top level of an importable module and name it "
                               f"'module:object'")
    return f"{module}:{found[0]}"


def _named_objects(value, path: str, where: str = ""):
    """Problem data with every ``object`` built in code (a custom term's or test's) written as its
    ``module:name``; ``path`` and ``where`` name the entry in a refusal."""
    if isinstance(value, dict):
        return {k: (_object_name(v, f"{path}: {where}") if k == "object" and not isinstance(v, str)
                    else _named_objects(v, path, f"{where}.{k}" if where else k)) for k, v in value.items()}
    if isinstance(value, list):
        return [_named_objects(v, path, f"{where}[{i}]") for i, v in enumerate(value)]
    return value


def problem_text(problem: DesignProblem) -> str:
    """The TOML text of ``problem``: its file's own text if it has one and nothing was changed,
    otherwise written from its data (``custom`` objects built in code by their ``module:name``)."""
    if problem.source_text is not None:
        return problem.source_text
    import tomli_w
    data = _named_objects(problem.data, problem.path)
    return f"# {problem.name}: written by pes_ref from {problem.path}\n" + tomli_w.dumps(data)
