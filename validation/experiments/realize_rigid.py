"""docs/realize.md's "Parts under the rigid engine": realized designs run in rigid contact.

``make realize-rigid`` (``python validation/experiments/realize_rigid.py``) runs the project's own
commands in-process for each variant: ``design ...`` (skipped when ``OUT/NAME.npz`` exists and
``--reuse`` is given), then for each candidate ``realize DESIGN --as contact --out DIR`` (the
default rule and pin radius; the parts as realized, or with what a machinist can choose without
a new design: ``--clearance``, a pin larger than its cut-out in the same plate, and
``--restitution``) and for each held-out seed
``evaluate DESIGN --realized DEVICE --engine both --seed S``. It prints one row per variant,
candidate and seed (the design's headline figure, the parts' under eq. (1) and in rigid contact,
each evaluation's wall time and the load) and writes them to ``OUT/realize_rigid.csv``. The
variants are the shipped designs of docs/realize.md's "Parts under the rigid engine" and, for its
"Realizable design for any problem", the example problems designed from their paths
(`PATHS_PROBLEMS`, design seeds `PATHS_SEEDS`), realized with their files' parts.
``--smoke`` designs with ``--smoke`` and evaluates 8 particles (seconds; for a try). ``--only
VARIANT``, ``--candidate CANDIDATE`` and ``--seed S`` (each repeatable) run a piece, written to
``OUT/realize_rigid_PID.csv``; with ``--reuse`` the pieces share the designs.
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
HELD_OUT, _cli, _figures = _study.HELD_OUT, _study._cli, _study._figures
DEFAULT_OUT = ROOT / "validation" / "out" / "realize_rigid"
#: name -> (file stem, the design command's arguments, the headline figure).
VARIANTS = {
    "latch_contact (shipped plan)": ("latch_contact", ["latch_contact"], "success_fraction"),
    "funnel, realizable, default plan (envelope)": ("funnel_envelope", ["funnel", "--set", "realizable=true"],
                                                    "in_band_fraction"),
    "funnel, realizable, strips": ("funnel_strips", ["funnel", "--set", "realizable=true", "--set",
                                                     "init_shape=strips"], "in_band_fraction"),
    "funnel, realizable, V start, linger 20": ("funnel_vee", ["funnel", "--set", "realizable=true", "--set",
                                                              "linger=20", "--set", "init_shape=vee"],
                                               "in_band_fraction"),
    "oscillator (default plan)": ("oscillator", ["oscillator", "--workers", "1"], "captured_fraction"),
}
LATCH, VEE = "latch_contact (shipped plan)", "funnel, realizable, V start, linger 20"
ENVELOPE = "funnel, realizable, default plan (envelope)"
#: The example problems designed as parts from no drawn shape (their start the passing paths of a
#: smooth design, `pes_ref.synthesis.engine.paths_start`), each on design seeds 0-3.
PATHS_PROBLEMS = ("offcentre_parts", "lanes_parts", "splitter_parts")
PATHS_SEEDS = (0, 1, 2, 3)
PATHS = tuple(f"{name}, design seed {seed}" for name in PATHS_PROBLEMS for seed in PATHS_SEEDS)
VARIANTS.update({f"{name}, design seed {seed}": (f"{name}_s{seed}", [str(ROOT / "examples" / "problems" / f"{name}.toml"),
                                                                       "--seed", str(seed)], "success_fraction")
                 for name in PATHS_PROBLEMS for seed in PATHS_SEEDS})
OWN = tuple(v for v in VARIANTS if v not in PATHS)
#: candidate -> (the variants it is tried on, the realize command's extra arguments): what a
#: machinist can choose without a new design (a pin larger than its cut-out, the parts' restitution).
CANDIDATES = {
    "pin 0.02, no clearance, inelastic": (OWN, ["--clearance", "0", "--restitution", "0"]),
    "the problem file's parts (clearance eq. (1)'s standoff, 0.0354; inelastic)": (PATHS, []),
    "clearance 0.03 (pin 0.05, the same plate)": ((LATCH, VEE, ENVELOPE), ["--clearance", "0.03", "--restitution",
                                                                          "0"]),
    "clearance 0.03, restitution 0.5": ((LATCH,), ["--clearance", "0.03", "--restitution", "0.5"]),
    "clearance 0.03, restitution 0.9": ((LATCH, VEE, ENVELOPE), ["--clearance", "0.03", "--restitution", "0.9"]),
    "no clearance, restitution 1": ((ENVELOPE,), ["--clearance", "0", "--restitution", "1"]),
    "clearance 0.035, restitution 1 (latch_contact.toml's)": ((LATCH, VEE), ["--clearance", "0.035",
                                                                             "--restitution", "1"]),
}


def _shares(figures: dict) -> str:
    """The rigid run's ``[[evaluate.share]]`` criteria: ``"2 of 2"`` met, or ``"-"`` (none)."""
    met = [v for k, v in figures.items() if k.startswith("rigid_share_") and k.endswith("_met")]
    return f"{sum(float(v) == 1.0 for v in met)} of {len(met)}" if met else "-"


def _load() -> str:
    return f"{os.getloadavg()[0]:.1f}"


def run(out: Path, smoke: bool, reuse: bool, names=None, seeds=HELD_OUT, candidates=None) -> list:
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name, (stem, args, headline) in VARIANTS.items():
        if names and name not in names:
            continue
        design = out / f"{stem}.npz"
        t_design = float("nan")
        if not (reuse and design.exists()):
            _, t_design = _cli(["design", *args, *(["--smoke"] if smoke else []), "--quiet", "--force",
                                "--out", str(design)])
        for i, (candidate, (applies, extra)) in enumerate(CANDIDATES.items()):
            if name not in applies or (candidates and candidate not in candidates):
                continue
            parts = out / f"{stem}_parts{i}"
            _, t_realize = _cli(["realize", str(design), "--as", "contact", "--out", str(parts), "--force",
                                 "--particles", "8", *extra])
            device = parts / "device.toml"
            for seed in seeds:
                load = _load()
                printed, t_eval = _cli(["evaluate", str(design), "--realized", str(device), "--engine", "both",
                                        "--seed", str(seed), *(["--particles", "8"] if smoke else [])])
                f = _figures(printed)
                rows.append({"variant": name, "candidate": candidate, "seed": seed, "figure": headline,
                             "design": f[headline], "soft": f[f"realized_{headline}"],
                             "rigid": f[f"rigid_{headline}"], "rigid_dt": f["rigid_dt"],
                             "blocked_starts": f.get("rigid_starts_blocked", "0"),
                             "rigid_shares": _shares(f),
                             "design_s": f"{t_design:.1f}", "realize_s": f"{t_realize:.1f}",
                             "evaluate_s": f"{t_eval:.1f}", "load": f"{load}-{_load()}"})
                print(" | ".join(str(v) for v in rows[-1].values()), flush=True)
    return rows


def table(rows: list) -> str:
    head = ["variant", "candidate", "seed", "figure", "design", "soft (eq. (1))", "rigid", "rigid dt",
            "starts in the parts", "rigid shares met", "design s", "realize s", "evaluate s (both engines)", "load"]
    return _study.markdown(head, list(rows[0]), rows)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, help="output folder")
    p.add_argument("--smoke", action="store_true", help="smoke designs, 8 held-out particles (seconds)")
    p.add_argument("--reuse", action="store_true", help="keep a design file OUT/NAME.npz that exists")
    p.add_argument("--only", action="append", default=None, metavar="VARIANT", help="run only this variant")
    p.add_argument("--candidate", action="append", default=None, metavar="CANDIDATE",
                   help="run only this candidate (a key of CANDIDATES)")
    p.add_argument("--seed", action="append", type=int, default=None, help="only this held-out seed")
    args = p.parse_args(argv)
    start = time.perf_counter()
    for key, given, known in (("only", args.only, VARIANTS), ("candidate", args.candidate, CANDIDATES)):
        unknown = [x for x in given or () if x not in known]
        if unknown:
            p.error(f"--{key} must be one of {', '.join(repr(k) for k in known)}, got {unknown[0]!r}")
    rows = run(args.out, args.smoke, args.reuse, args.only, tuple(args.seed or HELD_OUT), args.candidate)
    if not rows:
        p.error("no candidate given is tried on a variant given (CANDIDATES names the variants of each)")
    print(table(rows))
    piece = args.only or args.seed or args.candidate
    name = f"realize_rigid_{os.getpid()}.csv" if piece else "realize_rigid.csv"
    _study.write_csv(args.out / name, rows)
    print(f"wrote {args.out / name} ({time.perf_counter() - start:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
