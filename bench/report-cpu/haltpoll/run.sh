#!/bin/bash
# Alternates the guest's halt-poll limit between the host's 0 and the kernel default 200000 ns.
P=/sys/module/haltpoll/parameters/guest_halt_poll_ns
cd "$(dirname "$0")/../../.."  # the repository root
mkdir -p /tmp/haltpoll
for i in 1 2; do
  for ns in 0 200000; do
    echo $ns > $P
    echo "=== round $i guest_halt_poll_ns=$(cat $P) $(date -u +%H:%M:%S)"
    target/deploy/paced_cpu --repeats 1 --short 5 --long 30 --baseline-bin-dir target/deploy 2>&1 | grep -E "^(process|all|steady|controller|estimator|plant|logger|sim-|launcher|ground|testbed)"
  done
done
echo 0 > $P
echo "restored $(cat $P) $(date -u +%H:%M:%S)"
