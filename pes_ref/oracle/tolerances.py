"""Tolerances of the numerical contract (docs/spec.md section 11), as named constants.

Other implementations compare against the reference with these; the project's own
tests use them too, so that a tolerance is never loosened in one place only.
"""

#: Trajectories (x, v, energy, loss) of a conforming implementation, relative (docs/spec.md section 11).
TRAJ_RTOL = 1e-12
#: ... and the absolute floor under which entries count as zero.
TRAJ_ATOL = 1e-12
#: Gradients of a conforming implementation, relative (docs/spec.md section 11).
GRAD_RTOL = 1e-9
#: ... and the absolute floor, scaled by the largest entry of the gradient compared.
GRAD_ATOL = 1e-9
#: The adjoint against central finite differences, away from kinks: their relative difference is below this.
FD_RTOL = 1e-6
#: The default central-difference step, relative to the parameter's scale.
FD_EPS = 1e-6
