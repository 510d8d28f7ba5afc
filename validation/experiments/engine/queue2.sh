#!/bin/bash
# queue2.sh: wait for the running batch, then jobs11.txt (this folder's problems) and jobs11e.txt (the examples)
while pgrep -f "xargs -P 2 -L 1 ./batch" > /dev/null; do sleep 5; done
xargs -P 2 -L 1 ./batch.sh < jobs11.txt
xargs -P 2 -L 1 ./batch_examples.sh < jobs11e.txt
