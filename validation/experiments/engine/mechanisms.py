"""The candidate plans measured for issue 30 item 3: a mechanism name -> a finished DesignState.

``baseline``: the problem's own plan (the file's [train] or today's default).
``p,KEY=VALUE,...``: a Plan built here: lr, lrf (lr_final), it (iterations), n (particles),
st (stages: ``c4`` = 5 -> 9 -> 17 -> final at equal shares; ``c25`` = today's 25 then final at 80%),
opt (rmsprop/adam), clip, val (validate_every), vn (validation particles), tgt (target), sg (0: no lr scaling by grid).
``smooth,s=SIGMA,k=K``: the default plan with randomized smoothing (Suh et al. 2022): each
iteration's gradient is the mean of K gradients, each on the grid plus SIGMA times a normal draw
(masked like the design) with 1/K of the particles, so an iteration costs what the default's does.
``pop,k=STARTS,s=SCREEN[,c=COMPARED]``: the default plan with a population of starts (issue 41 item 3).
"""
import numpy as np
from pes_ref import synthesis
from pes_ref.synthesis.common.plans import Plan
from pes_ref.synthesis.engine.stages import run_stages


def baseline(problem, seed):
    return run_stages(synthesis.new_design(problem, seed=seed))


def _stages(spec, problem, its):
    n0 = problem.grid_shape[0]
    if spec.startswith("c") and spec[1:].isdigit() and int(spec[1:]) < 10:
        grids = [g for g in (5, 9, 17, 33, 65, 129) if g < n0][: int(spec[1:]) - 1] + [0]
        return tuple((its * i // len(grids), g) for i, g in enumerate(grids))
    if spec == "c25":
        return ((0, min(25, n0)), (int(0.8 * its), 0)) if n0 > 25 else ((0, 0),)
    raise ValueError(spec)


def planned(spec):
    kv = dict(item.split("=") for item in spec.split(",")[1:])

    def run(problem, seed):
        its = int(kv.get("it", 300))
        lr = float(kv.get("lr", 0.002))
        plan = Plan(iterations=its, lr=lr, lr_final=float(kv.get("lrf", lr)), decay_iterations=its,
                    optimizer=kv.get("opt", "rmsprop"), clip=float(kv["clip"]) if "clip" in kv else None,
                    stages=_stages(kv.get("st", "c25"), problem, its), n_particles=int(kv.get("n", 64)),
                    validate_every=int(kv.get("val", 0)), validation_particles=int(kv.get("vn", 200)),
                    target=float(kv["tgt"]) if "tgt" in kv else None, scale_lr_by_grid=kv.get("sg", "1") == "1")
        return run_stages(synthesis.new_design(problem, seed=seed, plan=plan))
    return run


def smoothed(spec):
    kv = dict(item.split("=") for item in spec.split(",")[1:])
    sigma, k = float(kv.get("s", 0.005)), int(kv.get("k", 4))

    def run(problem, seed):
        from pes_ref.synthesis.engine import training
        plain = training.design_step

        def step(problem, values, seed, iteration, n_particles, n_steps=None, backend=None):
            rng = np.random.default_rng([seed, iteration, 2 ** 32 + 7])
            mask = problem.mask(values.shape)
            parts = [plain(problem, values + sigma * rng.standard_normal(values.shape) * mask, seed,
                           iteration * k + j + 10 ** 6, max(1, n_particles // k), n_steps, backend)
                     for j in range(k)]
            return (float(np.mean([p[0] for p in parts])), np.mean([p[1] for p in parts], axis=0), parts[0][2],
                    parts[0][3])
        training.design_step = step
        try:
            return run_stages(synthesis.new_design(problem, seed=seed))
        finally:
            training.design_step = plain
    return run


def population(spec):
    """``pop,k=STARTS,s=SCREEN[,c=COMPARED]``: the problem's default plan with a population of ``STARTS``
    starts, chosen after ``SCREEN`` iterations (pes_ref.synthesis.engine.population), the best of the
    first ``COMPARED`` that pass some (default: the module's; ``c=1``, the first that passes, is the rule
    before issue 41's last turn)."""
    kv = dict(item.split("=") for item in spec.split(",")[1:])

    def run(problem, seed):
        import dataclasses
        from pes_ref.synthesis.engine import population as pop
        plan = dataclasses.replace(problem.plan, starts=int(kv.get("k", 4)), screen=int(kv.get("s", 150)))
        pop.COMPARED = int(kv.get("c", pop.COMPARED))
        return run_stages(synthesis.new_design(problem, seed=seed, plan=plan))
    return run


class _Mechanisms(dict):
    def __missing__(self, key):
        if key.startswith("pop"):
            return population(key)
        return smoothed(key) if key.startswith("smooth") else planned(key)


MECHANISMS = _Mechanisms(baseline=baseline)
