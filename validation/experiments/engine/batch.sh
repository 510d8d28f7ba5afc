#!/bin/bash
# batch.sh MECH PROBLEM SEEDS... : one process, results appended to logs/results.jsonl
mech=$1; prob=$2; shift 2
PYTHONPATH=/work/wt-engine /work/main/.venv/bin/python run.py $prob.toml "$mech" "$@" >> logs/results.jsonl 2>> logs/err.log
