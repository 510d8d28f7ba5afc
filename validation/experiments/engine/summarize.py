"""Summarize logs/results.jsonl: per (problem, mechanism): seeds with both held-out >= 0.9, mean min, mean wall."""
import json, sys, collections
rows = [json.loads(l) for l in open(sys.argv[1] if len(sys.argv) > 1 else "logs/results.jsonl")]
rows = [r for r in rows if r["status"] == "done"]      # runs I stopped (SIGTERM) are not results
g = collections.OrderedDict()
for r in rows:
    g.setdefault((r["mechanism"], r["problem"]), {})[r["seed"]] = r
for (m, p), d in g.items():
    seeds = sorted(d)
    good = sum(min(d[s]["success"]) >= 0.9 for s in seeds)
    mins = " ".join(f"{min(d[s]['success']):.2f}" for s in seeds)
    wall = sum(d[s]["wall_s"] for s in seeds) / len(seeds)
    its = sum(d[s]["iterations"] for s in seeds) / len(seeds)
    print(f"{m:45s} {p:14s} {good}/{len(seeds)}  min per seed: {mins}   wall {wall:.1f}s its {its:.0f}")
