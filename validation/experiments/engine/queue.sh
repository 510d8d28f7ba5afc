#!/bin/bash
# queue.sh JOBFILE: wait for the running batch, then run JOBFILE's lines two at a time
while pgrep -f "xargs -P 2 -L 1 ./batch.sh" > /dev/null; do sleep 5; done
xargs -P 2 -L 1 ./batch.sh < $1
