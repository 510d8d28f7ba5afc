"""The numerical core, the method: the grid lookup, surfaces and their interpolations (a
registry), energy terms, external forces, the hot loop's kernels, NumPy's steppers (a
registry) and their hand-derived adjoints, the registry of backends, objectives, the
stability limit, input checks, the scene layer (``Scene``, ``simulate``, ``value_and_grad``)
over them, and the readable reference. The accelerators (numba's compiled loops, NumPy's
two halves on two threads) are [`pes_ref.accel`][pes_ref.accel]: the registry of backends names
them and imports them on first use; nothing here imports them.

This is the lowest layer: nothing here imports from another subpackage of pes_ref
(``docs/architecture.md``; ``make test`` checks it with import-linter).
"""
