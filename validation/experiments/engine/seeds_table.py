"""A per-seed table of one study's log (one run.py JSON line per design): per problem and plan, each
design seed's held-out success on seeds 12345 / 9191 (and each scenario's), its iterations, wall
seconds (and CPU seconds where the log has them), and how many seeds reach 0.9 on both held-out seeds in the run and in every scenario.

    python seeds_table.py logs/phases.jsonl [PLAN ...]     # the plans in that order (default: all)
"""
import collections
import json
import sys


def passed(r) -> bool:
    return min(r["success"]) >= 0.9 and all(min(s) >= 0.9 for s in r.get("scenarios", {}).values())


def cell(r) -> str:
    figs = f"{r['success'][0]:.3f} / {r['success'][1]:.3f}"
    for name, s in r.get("scenarios", {}).items():
        figs += f"; {name} {s[0]:.3f} / {s[1]:.3f}"
    cpu = f", {r['cpu_s']:.1f} s CPU" if "cpu_s" in r else ""
    return f"{figs} ({r['iterations']} it, {r['wall_s']:.1f} s{cpu})"


def main(log, plans):
    rows = [json.loads(line) for line in open(log)]
    groups = collections.OrderedDict()
    for r in rows:
        groups.setdefault((r["mechanism"], r["problem"]), {})[r["seed"]] = r      # the last line of a seed counts
    plans = plans or list(dict.fromkeys(m for m, _ in groups))
    seeds = sorted({s for d in groups.values() for s in d})
    print("| plan | problem | " + " | ".join(f"seed {s}" for s in seeds) + " | seeds >= 0.9 | median s |")
    print("| --- | --- | " + " | ".join("---" for _ in seeds) + " | --- | --- |")
    for m in plans:
        for (mm, p), d in groups.items():
            if mm != m:
                continue
            walls = sorted(r["wall_s"] for r in d.values())
            median = 0.5 * (walls[(len(walls) - 1) // 2] + walls[len(walls) // 2])
            cells = " | ".join(cell(d[s]) if s in d else "" for s in seeds)
            print(f"| {m} | {p} | {cells} | {sum(map(passed, d.values()))} of {len(d)} | {median:.1f} |")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
