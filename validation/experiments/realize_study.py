"""The table of docs/realize.md ("Measured"): funnel designs realized by contact and re-simulated.

``make realize-study`` runs it (``python validation/experiments/realize_study.py``). For each
variant it runs the project's own commands in-process: ``design funnel ...`` (or, for the
V start alone, the starting shape saved as a design file with no iteration), ``realize DESIGN
--as contact --out DIR``, and ``evaluate DESIGN --realized DIR/device.toml --seed S`` for the
held-out seeds 12345 and 9191 (for :data:`SENSITIVITY`, also at the contact level's neighbours);
the variants of :data:`HEIGHTFIELD` are also realized as a heightfield and checked with the
rolling ball and in MuJoCo (``realize --as heightfield --seed S``, and with ``--steps`` twice the
design's: 700 for the funnel); it prints one row per variant and seed (the design's in-band
and exited fractions beside the realized device's, the realized step, each command's wall
time) and writes them to ``OUT/realize_study.csv``. ``--smoke`` uses the design command's
tiny preset (seconds; for the tests).

``--oscillator`` (``make realize-oscillator``) runs the oscillator instead: ``design
oscillator --seed 0`` (its default backend), ``realize --as contact`` (a drum cam, the
``visited`` rule) and at the rule's neighbouring levels, ``evaluate --realized`` on the held-out
seeds; each row holds the design's captured fraction beside the drum cam's, the flat surface's
(``evaluate DESIGN``), the blocked share and the step. Then :func:`walls` says what in the design
is not a wall: the share of the energy range and of the force the design's particles feel below
the contact level, and what the particles do on the drum cam (``OUT/realize_oscillator.csv``).
"""
from __future__ import annotations

import argparse
import contextlib
import csv
import io
import os
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_OUT = ROOT / "validation" / "out" / "realize_study"
HELD_OUT = (12345, 9191)
#: realize's own check of the parts' score, kept small: the study's figures are its evaluate runs.
SCORE_CHECK = ["--particles", "8"]
REALIZABLE = ["--set", "realizable=true"]
#: name -> the design command's options (None: the V start alone, saved with no iteration).
VARIANTS = {
    "default funnel (visited rule)": [],
    "realizable, envelope (the default plan)": REALIZABLE,
    "realizable, strips": REALIZABLE + ["--set", "init_shape=strips"],
    "realizable, strips, linger 1": REALIZABLE + ["--set", "linger=1", "--set", "init_shape=strips"],
    "realizable, strips, linger 20": REALIZABLE + ["--set", "linger=20", "--set", "init_shape=strips"],
    "realizable, V start alone": None,
    "realizable, V start, linger 1": REALIZABLE + ["--set", "linger=1", "--set", "init_shape=vee"],
    "realizable, V start, linger 20": REALIZABLE + ["--set", "linger=20", "--set", "init_shape=vee"],
}
#: The variants whose contact level's neighbours (the realize command's ``neighbour:`` lines) are
#: realized and evaluated too (``--rule value --level E``): how sensitive the result is to the level.
SENSITIVITY = ("default funnel (visited rule)",)
#: The variants also realized as a heightfield (``realize --as heightfield --seed S``): the rolling-ball
#: and MuJoCo checks, at the design's horizon and at :data:`HEIGHTFIELD_LONGER` times it (``--steps``).
HEIGHTFIELD = ("default funnel (visited rule)", "realizable, V start, linger 20")
HEIGHTFIELD_LONGER = 2
HEIGHTFIELD_FIGURES = ("max_slope", "slope_share_over_0.1", "steps", "in_band_fraction", "exited_fraction",
                       "rolling_in_band_fraction", "rolling_exited_fraction", "sloped_in_band_fraction",
                       "slope_exit_shift", "mujoco_in_band_fraction", "mujoco_exited_fraction", "mujoco_seconds")
FIGURES = ("in_band_fraction", "exited_fraction")


def _cli(argv: list) -> tuple:
    """Run ``python -m pes_ref ARGV`` in-process: (stdout, seconds); a failure raises."""
    from pes_ref.cli import main
    out, err = io.StringIO(), io.StringIO()
    start = time.perf_counter()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    if code != 0:
        raise SystemExit(f"pes_ref {' '.join(argv)} failed ({code}): {err.getvalue().strip()}")
    return out.getvalue(), time.perf_counter() - start


def _figures(text: str) -> dict:
    return dict(line.split(": ", 1) for line in text.splitlines() if ": " in line)


def _v_start(path: Path, smoke: bool) -> float:
    """The V start of a realizable funnel saved as a design file with no iteration."""
    from pes_ref.synthesis import KINDS, FunnelProblem, design_inputs, save_design, start_design
    start = time.perf_counter()
    params = {"realizable": True, "linger": 1.0, "init_shape": "vee"}
    if smoke:
        params.update(KINDS["funnel"].smoke.scene(None))
    state = start_design(design_inputs(FunnelProblem(), {}, params))
    state.status = "done"
    save_design(path, state, overwrite=True)
    return time.perf_counter() - start


#: The heightfield rows of the last :func:`run`.
HEIGHTFIELD_ROWS: list = []


def run(out: Path, smoke: bool, names=None) -> list:
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for i, (name, options) in enumerate(VARIANTS.items()):
        if names and name not in names:
            continue
        design = out / f"design{i}.npz"
        if options is None:
            t_design = _v_start(design, smoke)
        else:
            _, t_design = _cli(["design", "funnel", *options, *(["--smoke"] if smoke else []), "--quiet",
                                "--force", "--out", str(design)])
        parts = out / f"parts{i}"
        text, t_realize = _cli(["realize", str(design), "--as", "contact",
                                *SCORE_CHECK, "--out", str(parts), "--force"])
        rows += _evaluated(name, design, parts, text, t_design, t_realize)
        if name in HEIGHTFIELD:
            for seed in HELD_OUT:
                steps = []
                for _ in range(2):                   # the design's horizon, then HEIGHTFIELD_LONGER times it
                    more, t_hf = _cli(["realize", str(design), "--as", "heightfield", "--seed", str(seed), *steps,
                                       "--out", str(out / f"plate{i}"), "--force"])
                    got = _figures(more)
                    HEIGHTFIELD_ROWS.append({"variant": name, "seed": seed,
                                             **{k: got.get(k, "not run") for k in HEIGHTFIELD_FIGURES},
                                             "realize_s": f"{t_hf:.1f}"})
                    steps = ["--steps", str(HEIGHTFIELD_LONGER * int(got["steps"]))]
        if name not in SENSITIVITY:
            continue
        for k, line in enumerate(line for line in text.splitlines() if line.startswith("neighbour: ")):
            label, level = line.split(": ")[1], line.split("level ")[1].split(",")[0]
            other = out / f"parts{i}_{k}"
            more, t_more = _cli(["realize", str(design), "--as", "contact",
                                 *SCORE_CHECK, "--rule", "value", "--level", level,
                                 "--out", str(other), "--force"])
            rows += _evaluated(f"{name}, {label} (level {level})", design, other, more, t_design, t_more)
    return rows


def _evaluated(name, design, parts, realize_text, t_design, t_realize, figures=FIGURES) -> list:
    """One row per held-out seed: ``evaluate DESIGN --realized PARTS/device.toml``'s ``figures``
    beside their ``realized_`` ones, the realized step and each command's seconds."""
    realized = _figures(realize_text)
    rows = []
    for seed in HELD_OUT:
        text, t_eval = _cli(["evaluate", str(design), "--realized", str(parts / "device.toml"), "--seed", str(seed)])
        got = _figures(text)
        row = {"variant": name, "seed": seed, "rule": realized["rule"], "blocked_share": realized["blocked_share"],
               "iterations": got["iterations"]}
        for f in figures:
            row[f] = got[f]
            row[f"realized_{f}"] = got[f"realized_{f}"]
        row.update({"realized_dt": got["realized_dt"], "design_s": f"{t_design:.1f}", "realize_s": f"{t_realize:.1f}",
                    "evaluate_s": f"{t_eval:.1f}"})
        rows.append(row)
    return rows


#: The oscillator's columns: (header, row key).
OSC_COLUMNS = (("level", "variant"), ("seed", "seed"), ("blocked", "blocked_share"),
               ("device blocked", "device_blocked_share"), ("captured", "captured_fraction"),
               ("realized", "realized_captured_fraction"), ("realized sweep", "realized_sweep_captured_fraction"),
               ("realized grid", "realized_grid_captured_fraction"), ("flat", "flat_captured_fraction"),
               ("realized dt", "realized_dt"), ("design s", "design_s"), ("realize s", "realize_s"),
               ("evaluate s", "evaluate_s"))


def run_oscillator(out: Path, smoke: bool) -> tuple:
    """The oscillator's rows (one per contact level and held-out seed) and :func:`walls`' figures."""
    out.mkdir(parents=True, exist_ok=True)
    design = out / "oscillator.npz"
    _, t_design = _cli(["design", "oscillator", "--seed", "0", *(["--smoke"] if smoke else []), "--quiet",
                        "--force", "--out", str(design)])
    flat = {seed: _figures(_cli(["evaluate", str(design), "--seed", str(seed)])[0])["flat_captured_fraction"]
            for seed in HELD_OUT}
    parts = out / "drum"
    text, t_realize = _cli(["realize", str(design), "--as", "contact", *SCORE_CHECK, "--out", str(parts), "--force"])
    runs = [("visited (quantile 0.99)", parts, text, t_realize)]
    for k, line in enumerate(line for line in text.splitlines() if line.startswith("neighbour: ")):
        label, level = line.split(": ")[1], line.split("level ")[1].split(",")[0]
        other = out / f"drum_{k}"
        more, t_more = _cli(["realize", str(design), "--as", "contact",
                             *SCORE_CHECK, "--rule", "value", "--level", level,
                             "--out", str(other), "--force"])
        runs.append((f"{label} ({level})", other, more, t_more))
    rows = []
    for name, folder, realize_text, t_real in runs:
        realized = _figures(realize_text)
        for seed in HELD_OUT:
            got, t_eval = _cli(["evaluate", str(design), "--realized", str(folder / "device.toml"), "--seed", str(seed)])
            got = _figures(got)
            row = {"variant": name, "seed": seed, "level": realized["level"],
                   "blocked_share": realized["blocked_share"], "device_blocked_share": realized["device_blocked_share"],
                   "flat_captured_fraction": flat[seed]}
            for key in ("captured_fraction", "sweep_captured_fraction", "grid_captured_fraction"):
                row[key], row[f"realized_{key}"] = got[key], got[f"realized_{key}"]
            row.update({"realized_dt": got["realized_dt"], "design_s": f"{t_design:.1f}",
                        "realize_s": f"{t_real:.1f}", "evaluate_s": f"{t_eval:.1f}"})
            rows.append(row)
    return rows, walls(design, parts / "device.toml", float(_figures(text)["level"]))


def walls(design: Path, device_file: Path, level: float) -> dict:
    """What in the oscillator's design is not a wall, at contact ``level``: the share of its energy
    range and of its grid below the level; over every state of the ``visited`` rule's paths,
    the share of the force ``|grad E|`` the particles feel where the energy is below the level
    (flat on the drum cam beyond r_c of a wall); and on the drum cam, held-out seed 12345's
    torque sweep: the share that ends still swinging at 0.8 .. 1.2 of the target amplitude, the
    median amplitude and q1 advance per period of the particles not captured, beside q1's
    free run ``tau / damping1`` per unit time (median over the torques)."""
    import numpy as np
    from pes_ref.core.surface import Surface
    from pes_ref.devices.device_file import load_device
    from pes_ref.realize.evaluation import realized_problem
    from pes_ref.realize.hooks import held_out_positions
    from pes_ref.realize.regions import VISITED_SEED
    from pes_ref.synthesis import load_design
    from pes_ref.synthesis.kinds.analysis import cycle_figures, oscillator_torque_sweep, q1_advance
    state = load_design(design)
    problem, values = state.problem, state.values
    energy = np.asarray(problem.surface_values(values), dtype=np.float64)
    surface = Surface(energy, problem.lower, problem.upper, problem.periodic)
    x = held_out_positions(problem, values, VISITED_SEED).reshape(-1, 2)
    e = surface.energy(x)
    force = np.hypot(*np.moveaxis(surface.slope(x), -1, 0))
    run = realized_problem(problem, load_device(device_file))
    sweep = oscillator_torque_sweep(run.problem, run.values, 50, seed=HELD_OUT[0])
    amp, _, _, captured = cycle_figures(run.problem, sweep.traj)
    advance = q1_advance(run.problem, sweep.traj)
    free_run = np.median(sweep.torques) / problem.damping1 * problem.period
    lost = ~captured
    return {"energy_range_below_level": float((level - energy.min()) / np.ptp(energy)),
            "grid_below_level": float(np.mean(energy < level)),
            "force_share_below_level": float(force[e < level].sum() / force.sum()),
            "realized_swinging_0.8_1.2": float(np.mean(np.abs(amp - problem.amplitude) < 0.2 * problem.amplitude)),
            "realized_lost_amplitude_median": float(np.median(amp[lost])) if lost.any() else float("nan"),
            "realized_lost_q1_advance_median": float(np.median(advance[lost])) if lost.any() else float("nan"),
            "free_run_q1_advance_median": float(free_run),
            "realized_captured_torques": (f"{sweep.torques[captured].min():.3g} .. {sweep.torques[captured].max():.3g}"
                                          if captured.any() else "none")}


def markdown(head: list, keys: list, rows: list) -> str:
    """The rows as a Markdown table: columns ``head``, cells ``row[key]``."""
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(str(r[k]) for k in keys) + " |" for r in rows]
    return "\n".join(lines)


def write_csv(path, rows: list) -> None:
    """The rows as a CSV file with a header line (the first row's keys)."""
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def table(rows: list) -> str:
    head = ["variant", "seed", "rule", "blocked", "in band", "realized", "exited", "realized exited",
            "realized dt", "design s", "realize s", "evaluate s"]
    keys = ["variant", "seed", "rule", "blocked_share", "in_band_fraction", "realized_in_band_fraction",
            "exited_fraction", "realized_exited_fraction", "realized_dt", "design_s", "realize_s", "evaluate_s"]
    return markdown(head, keys, rows)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, help="output folder")
    p.add_argument("--smoke", action="store_true", help="the design command's tiny preset (seconds)")
    p.add_argument("--only", action="append", default=None, metavar="VARIANT", help="run only this variant")
    p.add_argument("--oscillator", action="store_true", help="the oscillator realized as a drum cam instead")
    args = p.parse_args(argv)
    if args.oscillator:
        return _main_oscillator(args)
    HEIGHTFIELD_ROWS.clear()
    rows = run(args.out, args.smoke, args.only)
    print(table(rows))
    if HEIGHTFIELD_ROWS:
        keys = list(HEIGHTFIELD_ROWS[0])
        print("\n" + markdown(keys, keys, HEIGHTFIELD_ROWS))
        write_csv(args.out / "realize_study_heightfield.csv", HEIGHTFIELD_ROWS)
    write_csv(args.out / "realize_study.csv", rows)
    print(f"wrote {os.path.join(args.out, 'realize_study.csv')}")
    return 0


def _main_oscillator(args) -> int:
    rows, figures = run_oscillator(args.out, args.smoke)
    print(markdown([h for h, _ in OSC_COLUMNS], [k for _, k in OSC_COLUMNS], rows))
    print("\n".join(f"{k}: {v:.4g}" if isinstance(v, float) else f"{k}: {v}" for k, v in figures.items()))
    write_csv(args.out / "realize_oscillator.csv", rows)
    print(f"wrote {os.path.join(args.out, 'realize_oscillator.csv')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
