"""The tables of docs/problems.md ("The funnel as a file", "The latch") from two sweeps' results.

Run the sweeps first (``make problems-study`` does all three steps)::

    python -m pes_ref sweep validation/experiments/problems_funnel.toml --out validation/out/sweeps/problems_funnel
    python -m pes_ref sweep validation/experiments/problems_latch.toml --out validation/out/sweeps/problems_latch
    python validation/experiments/problems_study.py

One row per design seed and held-out seed: the funnel's ``in_band`` (the file's one success
test), the latch's success per phase, all three together, the two checks (a hold twice as
long, no fire push) and the flat surface's; and each run's wall time (design and evaluation,
on the sweep's worker).
"""
from __future__ import annotations

import argparse
import csv
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SWEEPS = ROOT / "validation" / "out" / "sweeps"
HELD_OUT = ("12345", "9191")


def rows(path: Path) -> list:
    with open(path, newline="") as fh:
        return sorted((r for r in csv.DictReader(fh) if r["status"] == "ok"), key=lambda r: int(r["seed"]))


def funnel_table(runs: list) -> str:
    lines = ["| design seed | held-out seed | in_band | flat |", "| --- | --- | --- | --- |"]
    for r in runs:
        for h in HELD_OUT:
            lines.append(f"| {r['seed']} | {h} | {float(r[f'success_in_band@{h}']):.3f} | "
                         f"{float(r[f'flat_success_fraction@{h}']):.3f} |")
    return "\n".join(lines)


#: The latch's columns: (header, results.csv figure).
LATCH = (("load", "success_load"), ("hold", "success_hold"), ("fire", "success_fire"),
         ("all three", "success_fraction"), ("hold x2", "scenario_long_hold_success_fraction"),
         ("no fire push", "scenario_no_fire_success_fraction"), ("flat, all three", "flat_success_fraction"))


def latch_table(runs: list) -> str:
    lines = ["| design seed | held-out seed | " + " | ".join(h for h, _ in LATCH) + " | wall s |",
             "| --- | --- | " + " | ".join("---" for _ in LATCH) + " | --- |"]
    for r in runs:
        for h in HELD_OUT:
            cells = " | ".join(f"{float(r[f'{name}@{h}']):.3f}" for _, name in LATCH)
            lines.append(f"| {r['seed']} | {h} | {cells} | {float(r['wall_s']):.0f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--funnel", default=SWEEPS / "problems_funnel" / "results.csv", type=Path)
    p.add_argument("--latch", default=SWEEPS / "problems_latch" / "results.csv", type=Path)
    args = p.parse_args(argv)
    print("The funnel from its problem file\n\n" + funnel_table(rows(args.funnel)) + "\n")
    print("The latch\n\n" + latch_table(rows(args.latch)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
