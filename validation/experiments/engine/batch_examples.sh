#!/bin/bash
# batch_examples.sh MECH NAME SEEDS... : examples/problems/NAME.toml, results appended to logs/examples.jsonl
mech=$1; prob=$2; shift 2
PYTHONPATH=/work/wt-engine /work/main/.venv/bin/python run.py ../../../examples/problems/$prob.toml "$mech" "$@" >> logs/examples.jsonl 2>> logs/err_examples.log
