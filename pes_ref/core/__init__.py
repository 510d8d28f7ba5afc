"""The numerical core: the grid lookup, surfaces and their interpolations (a registry),
energy terms, external forces, the hot loop's kernels, the steppers (a registry) and
their hand-derived adjoints, objectives, the stability limit, input checks, and the
scene layer (``Scene``, ``simulate``, ``value_and_grad``) over them.

This is the lowest layer: nothing here imports from another subpackage of pes_ref
(``docs/architecture.md``; ``make test`` checks it with import-linter).
"""
