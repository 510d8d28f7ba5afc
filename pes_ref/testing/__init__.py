"""Helpers that other implementations import to test themselves against pes_ref.

- :mod:`pes_ref.testing.tolerances` the contract's tolerances as named constants
- :mod:`pes_ref.testing.conformance` run your simulate/gradient on the shipped vectors
- :mod:`pes_ref.testing.strategies` hypothesis strategies that draw valid scenes
  (needs the ``test`` extra: hypothesis)
- :mod:`pes_ref.testing.finite_differences` central differences and dot-product checks
"""
from .tolerances import FD_EPS, FD_RTOL, GRAD_ATOL, GRAD_RTOL, TRAJ_ATOL, TRAJ_RTOL

__all__ = ["FD_EPS", "FD_RTOL", "GRAD_ATOL", "GRAD_RTOL", "TRAJ_ATOL", "TRAJ_RTOL"]
