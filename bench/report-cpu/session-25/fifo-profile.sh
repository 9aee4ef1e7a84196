#!/bin/sh
# Writes `launch/profiles/simulation.toml` with the tick's processes (`cpus = "hot-path"`) at
# SCHED_FIFO priority 10 to stdout. Run from the repository's root:
#   sh bench/report-cpu/session-25/fifo-profile.sh > /tmp/simulation-fifo.toml
#   target/deploy/paced_cpu --repeats 3 --short 5 --long 30 \
#       --profile /tmp/simulation-fifo.toml --baseline-profile simulation
# A real-time policy needs root or CAP_SYS_NICE.
set -e
sed 's/^cpus = "hot-path"$/cpus = "hot-path"\nscheduling = { policy = "fifo", priority = 10 }/' \
    launch/profiles/simulation.toml
