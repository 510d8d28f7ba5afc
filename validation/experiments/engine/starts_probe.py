"""Each start of a run's population, followed to the end: which start would have been the right one.

    python starts_probe.py PROBLEM.toml SEED [SEED ...]

For each design seed SEED on the problem's default plan: each start j (pes_ref.synthesis.engine.population.start_seed)
screened to the plan's screen, judged on the run's validation particles (success, loss), then the run gone on from
it to the plan's end with the run's own batches; one JSON line per start: its judgment at the screen, its
best validation, its iterations, and the held-out successes of its delivered grid.
"""
import json
import sys
import time

from pes_ref import synthesis
from pes_ref.synthesis.engine import population as pop
from pes_ref.synthesis.engine.design_state import new_design
from pes_ref.synthesis.engine.stages import run_stages
from pes_ref.synthesis.engine.training import run_design
from pes_ref.synthesis.kinds.registry import HELD_OUT as _HELD

HELD_OUT = (_HELD["seed"], _HELD["second"])


def main():
    path, *seeds = sys.argv[1:]
    problem = synthesis.load_problem(path)
    plan = problem.plan
    for seed, j in ((int(seed), j) for seed in seeds for j in range(plan.starts)):
        t0 = time.perf_counter()
        state = new_design(problem, seed=seed, plan=plan)
        member = new_design(problem, seed=pop.start_seed(seed, j), plan=plan, polish=None)
        run_design(member, plan.screen, finish=False)
        screen_s = time.perf_counter() - t0
        judged = pop._judged(state, member)
        rec = {"problem": problem.name, "seed": seed, "start": j, "status_screen": member.status,
               "best_screen": None if member.best is None else member.best.success,
               "val_screen": member.validation["success"][-5:], "judged": judged[:2], "screen_s": round(screen_s, 1)}
        if member.status in ("running", "done"):
            pop._adopt(state, member, judged)
            run_stages(state)
            res = list(synthesis.evaluate_seeds(state.problem, state.values, HELD_OUT).values())
            rec.update(iterations=state.iteration, best=state.best.success, best_it=state.best.iteration,
                       val_tail=state.validation["success"][-8:],
                       success=[r["success_fraction"] for r in res])
        rec["wall_s"] = round(time.perf_counter() - t0, 1)
        print(json.dumps(rec), flush=True)


if __name__ == "__main__":
    main()
