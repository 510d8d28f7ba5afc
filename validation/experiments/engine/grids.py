"""Issue 41 item 3: the default plan on other coarse stages, a stage's grid given per axis.

    python grids.py PROBLEM.toml STAGES SEED

``STAGES`` is ``GRID@START;...``: from iteration START on, the grid has GRID nodes along axis 0 in
the final grid's proportion (0: the final grid), or ``N0xN1`` nodes per axis (``15x8@0;0@150``:
15 x 8 nodes for 150 iterations, then the final grid). The rest is the default plan. Prints the
held-out success on seeds 12345 and 9191, the iterations, the wall seconds and the first
iteration whose validation passed a particle. Its runs on the light overload release are
logs/grids.txt.
"""
import sys
import time
import types

from pes_ref import synthesis
from pes_ref.synthesis.common.plans import DEFAULT_FILE_PLAN, Plan
from pes_ref.synthesis.engine.stages import run_stages


def main(path, spec, seed):
    problem = synthesis.load_problem(path)
    stages, shapes = [], {}
    for item in spec.split(";"):
        grid, start = item.split("@")
        if "x" in grid:
            n0, n1 = map(int, grid.split("x"))
            shapes[n0], grid = (n0, n1), n0
        stages.append((int(start), int(grid)))
    plain = type(problem).shape
    problem.shape = types.MethodType(lambda self, grid=None: shapes.get(grid) or plain(self, grid), problem)
    plan = Plan(**DEFAULT_FILE_PLAN, decay_iterations=300, stages=tuple(stages))
    t0 = time.perf_counter()
    state = run_stages(synthesis.new_design(problem, seed=seed, plan=plan))
    wall = time.perf_counter() - t0
    held = [synthesis.evaluate(problem, state.values, seed=s)["success_fraction"] for s in (12345, 9191)]
    first = next((i for i, s in zip(*state.validation.values()) if s > 0), None)
    print(problem.name, spec, seed, held, state.iteration, round(wall, 1), "first>0 at", first, flush=True)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]))
