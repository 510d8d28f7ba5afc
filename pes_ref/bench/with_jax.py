"""The benchmark's design gradient by JAX (``jax.grad`` of a ``lax.scan``, under ``jax.jit``).

Optional: JAX is imported only here, and only when [`available`][pes_ref.bench.with_jax.available]
says it is installed (the ``bench`` extra). Importing this module's
[`gradient_fn`][pes_ref.bench.with_jax.gradient_fn] switches JAX to float64 (``jax_enable_x64``), as
docs/spec.md requires. The first call compiles; the benchmark reports that compile time apart from
the steady-state time of later calls.
"""
from __future__ import annotations

import importlib.util

import numpy as np

from pes_ref.bench.cases import DesignCase
from pes_ref.bench.spec import state_loss_fn, step_fn

__all__ = ["available", "gradient_fn"]

NAME = "jax"


def available() -> bool:
    """True when JAX can be imported."""
    return importlib.util.find_spec("jax") is not None


def gradient_fn(case: DesignCase):
    """A jitted function ``values -> (loss, dL/dvalues)`` for the case, by JAX."""
    import jax
    jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp

    force, step = step_fn(jnp, case)
    state_loss = state_loss_fn(jnp, case)
    fext = jnp.asarray(case.fext)
    times = jnp.asarray(case.dt * np.arange(case.n_steps + 1))
    x0, v0 = jnp.asarray(case.x0), jnp.asarray(case.v0)

    def loss(values):
        f0 = force(values, x0) + fext[0]

        def body(carry, inputs):
            x, v, f, total = carry
            fext_next, t = inputs
            x, v, f = step(values, x, v, f, fext_next)
            return (x, v, f, total + state_loss(x, v, t)), None

        init = (x0, v0, f0, state_loss(x0, v0, times[0]))
        (_, _, _, total), _ = jax.lax.scan(body, init, (fext[1:], times[1:]))
        return total

    vg = jax.jit(jax.value_and_grad(loss))

    def run(values):
        value, grad = vg(jnp.asarray(values, dtype=jnp.float64))
        grad = np.asarray(grad)          # waits for the result
        return float(value), grad

    return run
