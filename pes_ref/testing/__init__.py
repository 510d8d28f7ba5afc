"""Helpers that other implementations import to test themselves against pes_ref.

- [`pes_ref.oracle.tolerances`][pes_ref.oracle.tolerances] the contract's tolerances as named constants
- [`pes_ref.testing.check`][pes_ref.testing.check] ``python -m pes_ref check``: any program against the vectors
- [`pes_ref.testing.conformance`][pes_ref.testing.conformance] run your simulate/gradient on the shipped vectors
- [`pes_ref.testing.check`][pes_ref.testing.check] ``pes_ref check``: any program against the vectors and
  fresh random cases
- [`pes_ref.testing.draws`][pes_ref.testing.draws] the distribution of random valid scenes, over a NumPy
  Generator or any other source of draws
- [`pes_ref.testing.strategies`][pes_ref.testing.strategies] the same as hypothesis strategies (needs the
  ``test`` extra: hypothesis)
- [`pes_ref.testing.finite_differences`][pes_ref.testing.finite_differences] central differences and dot-product checks

and the plain properties, one topic per module, that take any ``simulate`` /
``value_and_grad`` with the signatures of [`pes_ref.simulate`][pes_ref.core.scene.simulate] and
[`pes_ref.value_and_grad`][pes_ref.core.scene.value_and_grad], run them on a
[`pes_ref.Scene`][pes_ref.core.scene.Scene], and return numbers
(errors, ratios, distances) that a test compares with a tolerance:

- [`pes_ref.testing.energy`][pes_ref.testing.energy] energy drift, its budget and its order in dt
- [`pes_ref.testing.kinks`][pes_ref.testing.kinks] where the force is not smooth, and how far a run stays from it
- [`pes_ref.testing.symmetries`][pes_ref.testing.symmetries] periodic shift and grid roll
- [`pes_ref.testing.gradient_check`][pes_ref.testing.gradient_check] gradients against finite differences, kink-aware
- [`pes_ref.testing.chaos`][pes_ref.testing.chaos] a chaotic scene and the gradient's growth rate

An implementation under test wraps its own entry points::

    def my_simulate(scene, x0, v0, *, fext="scene"):
        ...   # returns an object with x, v, f of shape (T+1, N, 2)

    def my_value_and_grad(scene, x0, v0, objective, *, regularization_weight=0.0,
                          wrt=None, fext="scene"):
        ...   # returns (loss, {name: gradient}, ...)

and the properties then read, for example::

    from pes_ref.testing import FD_RTOL, check_gradient_fd
    check = check_gradient_fd(my_value_and_grad, scene, x0, v0, objective,
                              simulate_fn=my_simulate)
    assert check.valid and check.max_error < FD_RTOL

The names below (the properties', the tolerances and [`relative_error`][pes_ref.oracle.compare.relative_error]) are
importable from ``pes_ref.testing`` itself; the strategies, which need hypothesis, from
[`pes_ref.testing.strategies`][pes_ref.testing.strategies].
"""
from pes_ref.oracle.compare import relative_error
from pes_ref.oracle.tolerances import FD_EPS, FD_RTOL, GRAD_ATOL, GRAD_RTOL, TRAJ_ATOL, TRAJ_RTOL
from pes_ref.testing.kinks import distance_to_kinks, kink_distance, kink_signature
from pes_ref.testing.energy import (DriftRatio, EnergyDrift, drift_ratio, energy_drift, energy_error_budget,
                                    grid_slope_bound, max_frequency, max_speed)
from pes_ref.testing.symmetries import ShiftCheck, check_grid_roll, check_periodic_shift, rolled_scene
from pes_ref.testing.gradient_check import (GradientCheck, check_gradient_fd, get_parameter, loss_conditioning,
                                            with_parameter)
from pes_ref.testing.chaos import chaotic_case, gradient_growth_rate

__all__ = [
    "FD_EPS", "FD_RTOL", "GRAD_ATOL", "GRAD_RTOL", "TRAJ_ATOL", "TRAJ_RTOL", "relative_error",
    "kink_distance", "distance_to_kinks", "kink_signature",
    "max_frequency", "max_speed", "EnergyDrift", "energy_drift", "grid_slope_bound", "energy_error_budget",
    "DriftRatio", "drift_ratio",
    "ShiftCheck", "check_periodic_shift", "rolled_scene", "check_grid_roll",
    "GradientCheck", "check_gradient_fd", "get_parameter", "with_parameter", "loss_conditioning",
    "chaotic_case", "gradient_growth_rate",
]
