"""The table of docs/synthesis.md "The funnel: eq. (5) at the exit" from a sweep's results.

Run the sweep first (``make funnel-study`` does both)::

    python -m pes_ref sweep validation/experiments/funnel_objective.toml --out validation/out/sweeps/funnel_objective
    python validation/experiments/funnel_objective.py [validation/out/sweeps/funnel_objective/results.csv]

One row per variant of ``funnel_objective.toml``: the mean and the worst ``in_band_fraction``
over every design seed and held-out seed, how many design seeds reach 0.9 on both held-out
seeds (the bar of docs/synthesis.md), the worst ``exited_fraction``, and the figures of design seeds
0, 1 and 2 (held-out 12345 / 9191).

``--misses VARIANT SEED [HELD_OUT]`` describes the held-out particles one of the sweep's designs
misses instead: where they start, where they exit, their q0 speed towards the target as they
exit, and their q0 at the run's last step.
"""
from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_CSV = ROOT / "validation" / "out" / "sweeps" / "funnel_objective" / "results.csv"
HELD_OUT = ("12345", "9191")
BAR = 0.9


def table(rows: list[dict]) -> str:
    """The markdown table, variants in the order of the file."""
    variants: dict[str, list[dict]] = {}
    for row in rows:
        if row["status"] == "ok":
            variants.setdefault(row["variant"], []).append(row)
    lines = ["| variant | in_band mean | worst | design seeds >= 0.9 on both | worst exited | seeds 0, 1, 2 (12345 / 9191) |",
             "| --- | --- | --- | --- | --- | --- |"]
    for name, runs in variants.items():
        runs.sort(key=lambda r: int(r["seed"]))
        share = [[float(r[f"in_band_fraction@{h}"]) for h in HELD_OUT] for r in runs]
        exited = [float(r[f"exited_fraction@{h}"]) for r in runs for h in HELD_OUT]
        flat = [x for pair in share for x in pair]
        passing = sum(min(pair) >= BAR for pair in share)
        first = ", ".join(f"{a:.3f} / {b:.3f}" for a, b in share[:3])
        lines.append(f"| {name} | {sum(flat) / len(flat):.3f} | {min(flat):.3f} | {passing} of {len(share)} | "
                     f"{min(exited):.3f} | {first} |")
    return "\n".join(lines)


def misses(design_file: str, held_out: int) -> str:
    """Where the held-out particles a design misses start and exit, and how they move as they exit."""
    from pes_ref.synthesis import exit_steps, funnel_paths, load_design

    state = load_design(design_file)
    p = state.problem
    paths = funnel_paths(p, state.values, 200, held_out)
    x, v = paths.traj.x, paths.traj.v
    step, exited = exit_steps(x, p.lower[1])
    i = np.arange(x.shape[1])
    exits = np.where(exited, x[step, i, 0], np.nan)
    miss = ~p.in_band(exits)
    inward = -np.sign(x[step, i, 0] - p.target) * v[step, i, 0]
    out = [f"{design_file}: when={p.when}, exit_zone={p.exit_zone:g}; held-out seed {held_out}: "
           f"{miss.sum()} of {miss.size} missed, {np.sum(miss & ~exited)} never exited"]
    for k in np.flatnonzero(miss):
        where = f"exits at q0 {exits[k]:+.2f} (step {step[k]}) moving {inward[k]:+.2f} towards the target" \
            if exited[k] else "never exits"
        out.append(f"  start q0 {paths.x0[k, 0]:+.2f}: {where}; q0 at the last step {x[-1, k, 0]:+.2f}")
    return "\n".join(out)


def _results(path: Path) -> list[dict]:
    if not path.is_file():
        raise FileNotFoundError(f"{path} does not exist; run the sweep first: python -m pes_ref sweep "
                                f"validation/experiments/funnel_objective.toml --out {path.parent}")
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def _design_of(rows: list[dict], words: list[str]) -> tuple[str, int]:
    """The design file and held-out seed that ``--misses VARIANT SEED [HELD_OUT]`` names."""
    if len(words) not in (2, 3) or not all(w.isdigit() for w in words[1:]):
        raise ValueError(f"--misses {' '.join(words)}: expected VARIANT SEED [HELD_OUT], seeds as integers >= 0")
    variant, seed, held_out = words[0], words[1], int(words[2]) if len(words) == 3 else 12345
    found = [r for r in rows if r["variant"] == variant and r["seed"] == str(int(seed))]
    if not found:
        raise ValueError(f"--misses {' '.join(words)}: no run of variant {variant!r} with seed {seed} in the "
                         f"results (variants: {', '.join(sorted({r['variant'] for r in rows}))})")
    return found[0]["design_file"], held_out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", nargs="?", default=str(DEFAULT_CSV), help="the sweep's results.csv")
    ap.add_argument("--misses", nargs="+", metavar="WORD",
                    help="VARIANT SEED [HELD_OUT]: describe the misses of one design of the sweep "
                         "(held-out seed default 12345)")
    args = ap.parse_args(argv)
    try:
        rows = _results(Path(args.results))
        if args.misses is None:
            print(table(rows))
            return 0
        design_file, held_out = _design_of(rows, args.misses)
        print(misses(design_file, held_out))
    except (OSError, ValueError) as exc:          # a design file moved away or not a design: one line too
        print(f"error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    import signal
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)       # `| head` ends the output quietly
    sys.exit(main())
