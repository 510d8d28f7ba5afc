# Everything runs inside a local virtual environment that the targets create themselves.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: all test test-thorough figures conformance venv clean

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

# Until the figures issue lands, the main job runs what exists: the conformance
# vectors are regenerated into a scratch folder and checked against the shipped ones.
figures: $(STAMP)
	$(PY) -m pes_ref conformance --check

conformance: $(STAMP)
	$(PY) -m pes_ref conformance --write

clean:
	rm -rf $(VENV) .pytest_cache .hypothesis build *.egg-info
