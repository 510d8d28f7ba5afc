"""The contract's tolerances, for tests: re-exported from their home,
:mod:`pes_ref.oracle.tolerances`."""
from pes_ref.oracle.tolerances import FD_EPS, FD_RTOL, GRAD_ATOL, GRAD_RTOL, TRAJ_ATOL, TRAJ_RTOL

__all__ = ["TRAJ_RTOL", "TRAJ_ATOL", "GRAD_RTOL", "GRAD_ATOL", "FD_RTOL", "FD_EPS"]
