"""The benchmark's design gradient by HIPS autograd (the tool the paper used).

Optional: autograd is imported only here, and only when [`available`][pes_ref.bench.with_autograd.available] says it is
installed (the ``bench`` extra). The computation is [`pes_ref.bench.spec`][pes_ref.bench.spec] driven by a
Python loop over the steps, reverse-mode differentiated by ``autograd.grad``.
"""
from __future__ import annotations

import importlib.util

import numpy as np

from pes_ref.bench.cases import DesignCase
from pes_ref.bench.spec import state_loss_fn, step_fn

__all__ = ["available", "gradient_fn"]

NAME = "autograd"


def available() -> bool:
    """True when autograd can be imported."""
    return importlib.util.find_spec("autograd") is not None


def gradient_fn(case: DesignCase):
    """A function ``values -> (loss, dL/dvalues)`` for the case, by autograd."""
    import autograd
    import autograd.numpy as anp
    from autograd.tracer import getval

    force, step = step_fn(anp, case, plain=getval)
    state_loss = state_loss_fn(anp, case)
    fext = case.fext
    times = case.dt * np.arange(case.n_steps + 1)

    def loss(values):
        x, v = case.x0, case.v0
        f = force(values, x) + fext[0]
        total = state_loss(x, v, times[0])
        for n in range(case.n_steps):
            x, v, f = step(values, x, v, f, fext[n + 1])
            total = total + state_loss(x, v, times[n + 1])
        return total

    vg = autograd.value_and_grad(loss)

    def run(values):
        value, grad = vg(np.asarray(values, dtype=np.float64))
        return float(value), np.asarray(grad)

    return run
