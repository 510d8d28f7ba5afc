"""Helpers that other implementations import to test themselves against pes_ref.

- :mod:`pes_ref.oracle.tolerances` the contract's tolerances as named constants
- :mod:`pes_ref.testing.conformance` run your simulate/gradient on the shipped vectors
- :mod:`pes_ref.testing.check` ``pes_ref check``: any program against the vectors and
  fresh random cases
- :mod:`pes_ref.testing.draws` the distribution of random valid scenes, over a NumPy
  Generator or any other source of draws
- :mod:`pes_ref.testing.strategies` the same as hypothesis strategies (needs the
  ``test`` extra: hypothesis)
- :mod:`pes_ref.testing.finite_differences` central differences and dot-product checks
- :mod:`pes_ref.testing.properties` energy drift, periodic shift, grid roll and
  finite-difference gradient checks for any ``simulate`` / ``value_and_grad``, and the
  kink detectors that keep finite differences honest
"""
from pes_ref.oracle.tolerances import FD_EPS, FD_RTOL, GRAD_ATOL, GRAD_RTOL, TRAJ_ATOL, TRAJ_RTOL

__all__ = ["FD_EPS", "FD_RTOL", "GRAD_ATOL", "GRAD_RTOL", "TRAJ_ATOL", "TRAJ_RTOL"]
