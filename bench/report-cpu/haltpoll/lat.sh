#!/bin/bash
P=/sys/module/haltpoll/parameters/guest_halt_poll_ns
cd "$(dirname "$0")/../../.."  # the repository root
mkdir -p /tmp/haltpoll
for i in 1 2; do
  for ns in 0 200000; do
    echo $ns > $P
    echo "=== round $i guest_halt_poll_ns=$(cat $P) $(date -u +%H:%M:%S)"
    target/deploy/latency --out /tmp/haltpoll/lat-$i-$ns --skip hop,sweep,paced,binaries --cycles 20000 --waits block > /tmp/haltpoll/lat-$i-$ns.log 2>&1
    echo "exit $? $(date -u +%H:%M:%S)"
  done
done
echo 0 > $P
echo "restored $(cat $P) $(date -u +%H:%M:%S)"
