#!/bin/bash
# queue_ex.sh JOBFILE: wait for the running batch, then run JOBFILE's lines two at a time (examples)
while pgrep -f "xargs -P 2 -L 1 ./batch" > /dev/null; do sleep 5; done
xargs -P 2 -L 1 ./batch_examples.sh < $1
