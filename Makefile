# Everything runs inside a local virtual environment that the targets create themselves.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: all test test-thorough figures validate oscillator-plans bench conformance venv clean

all: test

$(STAMP): setup.cfg pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

venv: $(STAMP)

test: $(STAMP)
	$(PY) -m pytest -q

test-thorough: $(STAMP)
	$(PY) -m pytest -q --hypothesis-profile=thorough

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

# The benchmark installs its optional extra (autograd, JAX) into the same venv first.
BENCH_STAMP := $(VENV)/.installed-bench
$(BENCH_STAMP): $(STAMP)
	$(PY) -m pip install --quiet -e '.[test,bench]'
	touch $(BENCH_STAMP)

bench: $(BENCH_STAMP)
	$(PY) -m pes_ref bench

conformance: $(STAMP)
	$(PY) -m pes_ref conformance --write

clean:
	rm -rf $(VENV) .pytest_cache .hypothesis build *.egg-info
