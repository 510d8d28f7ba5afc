"""The numerical core: the grid lookup, surfaces and their interpolations (a registry),
energy terms, external forces, the hot loop's kernels, the steppers (a registry) and
their hand-derived adjoints, objectives, the stability limit, input checks, and the
scene layer (``Scene``, ``simulate``, ``value_and_grad``) over them.

Nothing here imports from a layer above (the oracle, devices, synthesis, bench, cli,
testing); ``make test`` checks this with import-linter (``setup.cfg``).
"""
