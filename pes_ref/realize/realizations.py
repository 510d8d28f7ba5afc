"""The realizations of a saved design, by name: what each writes, its own options, how it is
prepared (everything checked and computed, nothing written) and how it is written, read back
and checked (`REALIZATIONS`; ``python -m pes_ref realize DESIGN.npz --as NAME``).

Options are the library's names (``pin_radius``, ``n_steps`` ...); an option that is None was
not given and takes the realization's default. A realization's report is a list of ``(name,
value)`` pairs, in the order they are printed.
"""
from __future__ import annotations

from typing import Callable, NamedTuple

from pes_ref.core import budget, checks
from pes_ref.core.checks import InputError

__all__ = ["Realization", "REALIZATIONS", "check_options", "realize"]


def _held_out_seed() -> int:
    from pes_ref.synthesis.kinds.registry import HELD_OUT          # here: the command's parser imports this module
    return HELD_OUT["seed"]


class Realization(NamedTuple):
    """One way to realize a design."""

    #: its own options (library names); given to another realization they are refused
    options: tuple
    #: ``files(problem)``: key -> (file name, what it is), known before anything is computed
    files: Callable
    #: ``prepare(state, name, options)``: the job, every input checked, nothing written
    prepare: Callable
    #: ``write(job, state, outputs, options, force)``: the files written and read back; the report
    write: Callable


def _given(options: dict, name: str, default):
    return default if options.get(name) is None else options[name]


# --------------------------------------------------------------------------- contact

def _contact_files(problem) -> dict:
    from pes_ref.realize.files import CONTACT_FILES
    from pes_ref.realize.followers import follower_for
    return CONTACT_FILES[follower_for(problem.periodic).name]


def _prepare_contact(state, name: str, options: dict):
    from pes_ref.realize.contact import CONTACT_DEFAULTS, realize_contact
    rule, level = options.get("rule"), options.get("level")
    if (level is not None) != (rule == "value"):
        raise InputError("level", f"level E goes with rule value (the contact level given), got level {level} "
                                  f"and rule {rule}", names=("level", "rule"))
    kept = {key: _given(options, key, CONTACT_DEFAULTS[key]) for key in ("pin_radius", "rim", "thickness")}
    return realize_contact(state.problem, state.values, rule, level, name=name, drum_radius=options.get("drum_radius"),
                           clearance=options.get("clearance"), restitution=options.get("restitution"),
                           units=_given(options, "units", CONTACT_DEFAULTS["units"]), **kept)


def _write_contact(real, state, outputs: dict, options: dict, force: bool) -> list:
    from pes_ref.devices.device_file import load_device
    from pes_ref.realize.evaluation import headline_scores
    from pes_ref.realize.files import check_contact, write_contact
    write_contact(real, state.problem, state.values, outputs, force)
    region = real.region
    report = [("rule", region.rule), ("level", float(region.level)), ("blocked_share", float(region.blocked_share))]
    report += [("neighbour", f"{label}: level {level:.6g}, blocked_share {share:.6g}, changed_share {changed:.6g}")
               for label, level, share, changed in real.sensitivity]
    report += [("lost", line) for line in real.lost]
    scores = headline_scores(state.problem, state.values, load_device(outputs["device"]),
                             _given(options, "seed", _held_out_seed()), options.get("n_particles"))
    return report + list(check_contact(real, outputs).items()) + list(scores.items())


# --------------------------------------------------------------------------- heightfield

def _heightfield_files(problem) -> dict:
    from pes_ref.realize.files import HEIGHTFIELD_FILES
    return HEIGHTFIELD_FILES


def _prepare_heightfield(state, name: str, options: dict):
    from pes_ref.realize.heightfield import HEIGHTFIELD_DEFAULTS, check_base, check_heightfield_kind, heightfield
    check_heightfield_kind(state.problem)
    seed = checks.as_nonneg_int("seed", _given(options, "seed", _held_out_seed()))
    n = checks.as_positive_int("n_particles", _given(options, "n_particles", 200))
    given_steps = options.get("n_steps")
    steps = state.problem.n_steps if given_steps is None else checks.as_positive_int("n_steps", given_steps)
    budget.check_memory(steps, n, "simulate", particles="n_particles", fixed_steps=True, runs=4,
                        length=f"a held-out run of {steps} steps")
    hf = heightfield(state.problem, state.values, _given(options, "g", HEIGHTFIELD_DEFAULTS["g"]))
    base = check_base(hf, _given(options, "base", HEIGHTFIELD_DEFAULTS["base"]))
    return hf, base, seed, n, None if given_steps is None else steps


def _write_heightfield(job, state, outputs: dict, options: dict, force: bool) -> list:
    """The plate written, read back, and the rolling-ball check on the heights read back."""
    from pes_ref.realize.files import write_heightfield
    from pes_ref.realize.heightfield import heightfield_check
    hf, base, seed, n, n_steps = job
    read_back, figures = write_heightfield(hf, base, outputs["stl"], force)
    figures.update(seed=seed, particles=n)
    figures.update(heightfield_check(state.problem, state.values, read_back, seed, n, n_steps))
    return list(figures.items())


#: The realizations: ``--as NAME`` -> `Realization` (``docs/realize.md``).
REALIZATIONS = {
    "contact": Realization(("rule", "level", "pin_radius", "rim", "thickness", "drum_radius", "clearance",
                            "restitution", "units"), _contact_files, _prepare_contact, _write_contact),
    "heightfield": Realization(("g", "base", "n_steps"), _heightfield_files, _prepare_heightfield,
                               _write_heightfield),
}


def check_options(kind: str, options: dict) -> Realization:
    """Realization ``kind``, refusing (one line naming both) an option of another one given."""
    if kind not in REALIZATIONS:
        raise InputError("as", f"as must be one of {', '.join(REALIZATIONS)}, got {kind!r}")
    for other, realization in REALIZATIONS.items():
        for key in realization.options if other != kind else ():
            if options.get(key) is not None:
                raise InputError(key, f"{key} goes with as {other}, not as {kind}", names=(key, "as"))
    return REALIZATIONS[kind]


def realize(state, kind: str, outputs: dict, options: dict, *, name: str = "design", force: bool = False) -> list:
    """Realize the loaded design ``state`` as ``kind`` into ``outputs`` (key -> path, the keys
    of its ``files``); the report's ``(name, value)`` pairs."""
    realization = check_options(kind, options)
    job = realization.prepare(state, name, options)
    return realization.write(job, state, outputs, options, force)
