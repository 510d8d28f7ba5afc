# Everything runs inside a local virtual environment that the targets create themselves.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: all test test-random test-thorough figures validate oscillator-plans oscillator-table funnel-study problems-study design-study realize-study realize-oscillator rigid-devices realize-rigid bench conformance check-example docs venv clean

all: test

$(STAMP): setup.cfg pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

venv: $(STAMP)

# The whole suite on two processes (pytest-xdist; each test file's tests stay in one process,
# in file order); tests/project/test_architecture.py runs lint-imports on the layer and cycle
# contracts of setup.cfg. `$(PY) -m pytest -q` runs it in one process.
test: $(STAMP)
	$(PY) -m pytest -q -n 2 --dist loadfile -m "not thorough"

# The suite in a random order (pytest-randomly; the seed is printed: rerun an order with
# --randomly-seed=N): no test may depend on another having run. The plugin leaves NumPy's
# global random state alone (--randomly-dont-reset-seed): tests/core/test_forces.py watches it.
test-random: $(STAMP)
	$(PY) -m pytest -p randomly --randomly-dont-reset-seed

# The whole suite, the tests marked thorough included, with 10x the property tests' examples.
test-thorough: $(STAMP)
	$(PY) -m pytest -q -n 2 --dist loadfile --hypothesis-profile=thorough

# The documentation site into site/ (mkdocs.yml: the docs/ pages and the API reference that
# mkdocstrings renders from the docstrings), built strictly: a warning, such as a broken
# reference, fails it. tests/project/test_docs_site.py builds it too, into a scratch folder.
docs: $(STAMP)
	$(PY) -m mkdocs build --strict

# The paper's figures into figures/out/ (PNG + PDF): the two designs by `pes_ref design`
# (cached in figures/out/cache while pes_ref's sources are unchanged), then one script per
# figure; step times in figures/out/timings.json. See docs/figures.md.
figures: $(STAMP)
	$(PY) figures/make_all.py

# validation/: every script prints its table and saves its plot; run_all.py writes REPORT.md.
validate: $(STAMP)
	$(PY) validation/run_all.py

# The oscillator training plans of docs/synthesis.md (more than an hour on 2 cores): the plans
# that are design options and the seeds study as sweeps (validation/experiments/*.toml; a second
# run skips finished runs and resumes the others), then the plans that need their own code
# (oscillator_plans.py --all: every plan whose record is missing from validation/out/oscillator_plans/).
oscillator-plans: $(STAMP)
	$(PY) -m pes_ref sweep validation/experiments/oscillator_plans.toml --out validation/out/sweeps/oscillator_plans
	$(PY) -m pes_ref sweep validation/experiments/oscillator_seeds.toml --out validation/out/sweeps/oscillator_seeds
	$(PY) validation/experiments/oscillator_plans.py --all

# The default oscillator's table of docs/synthesis.md ("Results: three design seeds, two held-out
# seeds"): `design oscillator --seed S --backend B` for S = 0, 1, 2 on each installed backend, two
# at a time, each evaluated on held-out seeds 12345 and 9191; the lines between the table's
# markers are rewritten, nothing else (14 minutes at load 3.5-7.5; design files in
# validation/out/oscillator_table/).
oscillator-table: $(STAMP)
	$(PY) validation/experiments/oscillator_table.py

# The funnel study of docs/synthesis.md 11 settings x 16 design seeds, each evaluated
# on held-out seeds 12345 and 9191 (about 7 minutes on 2 cores), then its table.
funnel-study: $(STAMP)
	$(PY) -m pes_ref sweep validation/experiments/funnel_objective.toml --out validation/out/sweeps/funnel_objective
	$(PY) validation/experiments/funnel_objective.py validation/out/sweeps/funnel_objective/results.csv

# The problem files of docs/problems.md at full size: the funnel from its file and the latch, design
# seeds 0-2 each, on held-out seeds 12345 and 9191 (about 4 minutes on 2 cores), then their tables.
# docs/realize.md's tables: funnel and latch designs realized by contact and re-simulated on held-out seeds.
realize-study: $(STAMP)
	$(PY) validation/experiments/realize_study.py
	$(PY) validation/experiments/realize_latch.py

# docs/realize.md's oscillator table: the oscillator realized as a drum cam and re-simulated.
realize-oscillator: $(STAMP)
	$(PY) validation/experiments/realize_study.py --oscillator --out validation/out/realize_oscillator

# docs/realize.md's "Parts under the rigid engine" and "Realizable design for any problem": the
# latch, three realizable funnels, the oscillator and the example problems designed from their
# paths (design seeds 0-3) realized by contact, each (and the candidates tried) evaluated under
# eq. (1) and in rigid contact on held-out seeds 12345 and 9191 (needs pymunk: the extra rigid).
realize-rigid: $(STAMP)
	$(PY) validation/experiments/realize_rigid.py

# docs/problems.md's design study: every shipped problem and example without its [train] table (the
# default plan), design seeds 0-7 on each installed backend, evaluated on held-out seeds 12345 and
# 9191; the table between its markers is rewritten (validation/out/design_study/results.csv).
design-study: $(STAMP)
	$(PY) validation/experiments/design_study.py

problems-study: $(STAMP)
	$(PY) -m pes_ref sweep validation/experiments/problems_funnel.toml --out validation/out/sweeps/problems_funnel
	$(PY) -m pes_ref sweep validation/experiments/problems_latch.toml --out validation/out/sweeps/problems_latch
	$(PY) validation/experiments/problems_study.py

# docs/rigid.md's table: the shipped devices (the Geneva, cam-follower and drum-cam examples, the
# ratchet, the dart gun) driven in both modes on the surface and the rigid engine (pymunk, the
# extra `rigid`, in `test`); the table between its markers is rewritten, the rows go to
# validation/out/rigid_devices/rows.json (about 30 s at load 14 on 2 cores).
rigid-devices: $(STAMP)
	$(PY) validation/experiments/rigid_devices.py

# The benchmark installs its optional extra (autograd, JAX) into the same venv first.
BENCH_STAMP := $(VENV)/.installed-bench
$(BENCH_STAMP): $(STAMP)
	$(PY) -m pip install --quiet -e '.[test,bench]'
	touch $(BENCH_STAMP)

bench: $(BENCH_STAMP)
	$(PY) -m pes_ref bench

conformance: $(STAMP)
	$(PY) -m pes_ref conformance --write

# The independent JAX implementation of examples/jax_pes/, checked for real: its framework
# goes into a venv of its own (never a dependency of pes_ref), then `pes_ref check` runs it
# on the shipped vectors plus 100 fresh random cases (the valid and random cases in one process,
# the invalid ones in another).
EXAMPLE_VENV  := .venv-jax
EXAMPLE_PY    := $(EXAMPLE_VENV)/bin/python
EXAMPLE_STAMP := $(EXAMPLE_VENV)/.installed
$(EXAMPLE_STAMP): examples/jax_pes/requirements.txt
	$(PYTHON) -m venv $(EXAMPLE_VENV)
	$(EXAMPLE_PY) -m pip install --quiet --upgrade pip
	$(EXAMPLE_PY) -m pip install --quiet -r examples/jax_pes/requirements.txt
	touch $(EXAMPLE_STAMP)

check-example: $(STAMP) $(EXAMPLE_STAMP)
	$(PY) -m pes_ref check --cmd "$(EXAMPLE_PY) examples/jax_pes/pes_jax.py {pairs}" --random 100 --seed 1

clean:
	rm -rf $(VENV) $(EXAMPLE_VENV) .pytest_cache .hypothesis build *.egg-info
