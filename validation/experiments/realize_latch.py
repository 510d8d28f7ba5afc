"""The latch's rows of docs/realize.md ("The latch"): latch designs realized by contact and re-simulated.

``make realize-study`` runs it after the funnel's study
(``python validation/experiments/realize_latch.py``). For each variant it runs the project's own
commands in-process: ``design latch_contact ...`` (the shipped realizable latch, a level set
starting from a tooth and a cam; for the starting shapes alone, saved as a design file with no
iteration) or ``design latch --set surface.contact=...`` (the smooth latch, its contact stated),
``realize DESIGN --as contact --clearance 0 --restitution 0 --out DIR`` (the default rule:
``level-set`` or ``visited``; the parts of the design's own shape) and
``evaluate DESIGN --realized DIR/device.toml --seed S`` for the held-out seeds 12345 and 9191; it
prints one row per variant and seed (the design's success fractions beside the realized
device's, each command's wall time) and writes them to ``OUT/realize_latch.csv``. ``--smoke``
runs 2 iterations of each design on the shipped grids (seconds; for the tests).
"""
from __future__ import annotations

import argparse
import importlib.util
import os
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
_SPEC = importlib.util.spec_from_file_location("realize_study", Path(__file__).with_name("realize_study.py"))
_study = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(_study)
HELD_OUT, _cli, SCORE_CHECK = _study.HELD_OUT, _study._cli, _study.SCORE_CHECK      # the funnel study's runner
DEFAULT_OUT = ROOT / "validation" / "out" / "realize_latch"
#: The parts of the design's own shape: the pin 0.02 exactly, inelastic (latch_contact.toml's clearance
#: and restitution are for rigid parts: realize_rigid.py).
EXACT = ["--clearance", "0", "--restitution", "0"]
#: The smooth latch's contact: latch_contact.toml's eq. (1).
SMOOTH_CONTACT = "surface.contact={ v = 0.0012, r_c = 0.1, r_min = 0.03 }"
#: name -> the design command's arguments (None: the starting shapes alone, saved with no iteration).
VARIANTS = {
    "latch_contact, starting shapes alone": None,
    "latch_contact, shipped plan (20 iterations, lr 5e-5)": ["latch_contact"],
    "latch_contact, 200 iterations, lr 5e-5": ["latch_contact", "--iterations", "200"],
    "latch_contact, 200 iterations, lr 2e-4": ["latch_contact", "--iterations", "200", "--lr", "0.0002"],
    "smooth latch (latch.toml), visited rule": ["latch", "--set", SMOOTH_CONTACT],
}
FIGURES = ("success_fraction", "scenario_long_hold_success_fraction", "scenario_no_fire_success_fraction")


def _starting_shapes(path: Path) -> float:
    """latch_contact's starting shapes saved as a design file with no iteration."""
    from pes_ref.synthesis import design_inputs, load_problem, save_design, shipped_problem, start_design
    start = time.perf_counter()
    state = start_design(design_inputs(load_problem(shipped_problem("latch_contact")), {}))
    state.status = "done"
    save_design(path, state, overwrite=True)
    return time.perf_counter() - start


def run(out: Path, smoke: bool, names=None) -> list:
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for i, (name, args) in enumerate(VARIANTS.items()):
        if names and name not in names:
            continue
        design = out / f"design{i}.npz"
        if args is None:
            t_design = _starting_shapes(design)
        else:
            if smoke:
                args = [a for a in args if a not in ("--iterations", "200")] + ["--iterations", "2"]
            _, t_design = _cli(["design", *args, "--quiet", "--force", "--out", str(design)])
        parts = out / f"parts{i}"
        text, t_realize = _cli(["realize", str(design), "--as", "contact", *SCORE_CHECK, *EXACT,
                                "--out", str(parts), "--force"])
        rows += _study._evaluated(name, design, parts, text, t_design, t_realize, FIGURES)
    return rows


def table(rows: list) -> str:
    head = ["variant", "seed", "rule", "blocked", "iterations", "success", "realized", "long hold",
            "realized long hold", "no fire", "realized no fire", "realized dt", "design s", "realize s", "evaluate s"]
    keys = ["variant", "seed", "rule", "blocked_share", "iterations"] + [
        k for f in FIGURES for k in (f, f"realized_{f}")] + ["realized_dt", "design_s", "realize_s", "evaluate_s"]
    return _study.markdown(head, keys, rows)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, help="output folder")
    p.add_argument("--smoke", action="store_true", help="2 iterations per design (seconds)")
    p.add_argument("--only", action="append", default=None, metavar="VARIANT", help="run only this variant")
    args = p.parse_args(argv)
    rows = run(args.out, args.smoke, args.only)
    print(table(rows))
    _study.write_csv(args.out / "realize_latch.csv", rows)
    print(f"wrote {os.path.join(args.out, 'realize_latch.csv')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
