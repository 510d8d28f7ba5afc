#!/bin/bash
# batch.sh MECHANISM PROBLEM.toml SEED... : one process (run.py) of the comparison of docs/problems.md
# ("The default plan"), its JSON lines appended to logs/results.jsonl (this folder's problems) or
# logs/examples.jsonl (examples/problems/). Every run of the table: `xargs -P 2 -L 1 ./batch.sh < jobs.txt`
# (two at a time), run in this folder; `python table.py [--examples]` then prints the tables.
cd "$(dirname "$0")"
mech=$1; prob=$2; shift 2
case $prob in ../*) log=examples ;; *) log=results ;; esac
log=${LOG:-$log}        # LOG=NAME: logs/NAME.jsonl instead (a study of its own, e.g. LOG=phases)
PYTHONPATH=../../.. nice -n 19 "${PYTHON:-../../../.venv/bin/python}" run.py "$prob" "$mech" "$@" >> logs/$log.jsonl 2>> logs/err.log
