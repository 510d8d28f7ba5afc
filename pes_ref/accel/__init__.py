"""The accelerators: the same method as [`pes_ref.core`][pes_ref.core], run faster.

- [`compiled`][pes_ref.accel.compiled]: the dynamic and quasistatic loops, their adjoints and a
  trajectory's energy as numba kernels (the backend ``"numba"``, the optional extra ``fast``);
- [`halves`][pes_ref.accel.halves]: a NumPy run of many particles as two halves on two threads
  (the backend ``"numpy"`` from `pes_ref.accel.halves.MIN_PARTICLES` particles on).

Each plugs into `pes_ref.core.backends.BACKENDS`, which names its module and imports it on
first use: nothing else of pes_ref imports this package (setup.cfg's import-linter
contracts), and nothing here is needed to read the method.
"""
