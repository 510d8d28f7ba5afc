"""A realizable problem file's start when it draws none: the region its smooth design's passing paths cover.

A problem file with ``[surface.contact] realizable = true`` and no ``blocked`` shapes
(``docs/problems.md``) starts from a shape made from the problem, in two runs of its own:

1. **a smooth design**: the same problem with its level set off (``problem.plain()``) designed by
   the default plan of a problem file (`pes_ref.synthesis.common.plans.default_plan`: coarse
   stages and a population of starts), as many iterations as the run, from design seed
   `smooth_seed`\\ ``(seed)``; it delivers its best validated grid;
2. **its paths' region**: the passing paths of `PATHS_PARTICLES` of its particles (path seed
   ``default_rng([seed, PATHS_STREAM])``), as tubes joined with the starts and held boxes, closed,
   opened and filled ([`pes_ref.synthesis.problem.paths_region`][pes_ref.synthesis.problem.paths_region]);
   its signed distance is the level set's start.

The run then follows its own plan, and ends on its delivered shape smoothed as the start was
(``DesignProblem.final_values``).

What [`paths_start`][pes_ref.synthesis.engine.paths_start.paths_start] returns is a function of the
problem, the seed, the iteration count and the backend only, so the same run gives the same start
to the bit. The start is made once, when a fresh run starts (a resumed run holds its grid).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from pes_ref.core.runtime.extras import found
from pes_ref.devices.geometry import require_shapely
from pes_ref.synthesis.common.plans import default_plan
from pes_ref.synthesis.engine.design_state import new_design
from pes_ref.synthesis.engine.stages import run_stages
from pes_ref.synthesis.problem.paths_region import PATHS_PARTICLES, free_region, passing_paths, region_distance

__all__ = ["PATHS_STREAM", "SMOOTH_STREAM", "needs_paths_start", "smooth_seed", "paths_start"]

#: The second entry of ``default_rng([seed, PATHS_STREAM])``, the seed of the particles whose paths make the region.
PATHS_STREAM = 2 ** 32 + 5
#: The second entry of ``SeedSequence([seed, SMOOTH_STREAM])``, which gives the smooth design's seed.
SMOOTH_STREAM = 2 ** 32 + 6


def needs_paths_start(problem) -> bool:
    """Whether ``problem`` is a realizable problem file's design that draws no starting shape."""
    return bool(getattr(problem, "paths_start", False))


def smooth_seed(seed: int) -> int:
    """The design seed of the smooth design behind a run of design seed ``seed``: a 32-bit draw of
    ``SeedSequence([seed, SMOOTH_STREAM])``."""
    return int(np.random.SeedSequence([seed, SMOOTH_STREAM]).generate_state(1)[0])


def paths_start(problem, seed: int, iterations: int, backend: str | None = None, callback=None) -> tuple:
    """``(values, smooth)``: the start of a realizable ``problem`` without drawn shapes (module
    docstring) on its problem grid, the level set's grid values, and the smooth design's state.
    The smooth design runs ``iterations`` (the run's own count) on ``backend``; ``callback``
    receives its progress.

    Raises
    ------
    MissingExtraError
        (an ImportError) Without shapely or contourpy (the optional extra ``realize``), before any run.
    KeyboardInterrupt
        If Ctrl-C or SIGTERM stopped the smooth design: a fresh run has nothing to keep yet, so
        the command stops as it does on a second Ctrl-C."""
    found("contourpy", "realize", "a design from its paths (its shape's contour)")    # before any run: the
    require_shapely()                                                       # end's smoothing needs both
    plain = problem.plain()
    plan = default_plan(problem.grid_shape, coarse=True, iterations=iterations)
    plan = dataclasses.replace(plan, iterations=iterations, decay_iterations=iterations)
    smooth = new_design(plain, seed=smooth_seed(seed), plan=plan, backend=backend)
    smooth = run_stages(smooth, iterations, callback=callback)
    if smooth.status == "interrupted":         # Ctrl-C or SIGTERM while the start is made: the run stops
        raise KeyboardInterrupt
    paths_seed = int(np.random.default_rng([seed, PATHS_STREAM]).integers(2 ** 31))
    paths = passing_paths(plain, smooth.values, paths_seed, PATHS_PARTICLES)
    shape = problem.shape()
    distance = region_distance(problem, free_region(problem, paths), shape)
    return problem.level_set.from_distance(distance) * problem.mask(shape), smooth
