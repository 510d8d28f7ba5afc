"""The benchmark (``python -m pes_ref bench``): what accuracy and each effect cost in time.

- [`pes_ref.bench.benchmark`][pes_ref.bench.benchmark]      the measurements
- [`pes_ref.bench.targets`][pes_ref.bench.targets]        the targets, read off the measurements
- [`pes_ref.bench.report`][pes_ref.bench.report]         the report's tables
- [`pes_ref.bench.outputs`][pes_ref.bench.outputs]        the JSON and the scaling plot
- [`pes_ref.bench.cases`][pes_ref.bench.cases]          the benchmark's scenes
- [`pes_ref.bench.oracle_cli`][pes_ref.bench.oracle_cli]     what ``python -m pes_ref oracle`` costs around its
  computation (funnel)
- [`pes_ref.bench.spec`][pes_ref.bench.spec]           the step written for autodiff frameworks
- [`pes_ref.bench.with_autograd`][pes_ref.bench.with_autograd] / [`pes_ref.bench.with_jax`][pes_ref.bench.with_jax]  the
  optional comparisons
"""
from pes_ref.bench.benchmark import FULL, QUICK, Config, run
from pes_ref.bench.outputs import write_outputs
from pes_ref.bench.report import format_report

__all__ = ["Config", "FULL", "QUICK", "run", "format_report", "write_outputs"]
