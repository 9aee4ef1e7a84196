#!/bin/bash
cd "$(dirname "$0")/../../.."  # the repository root
mkdir -p /tmp/haltpoll
for i in 1 2 3 4 5 6; do
  echo "=== run $i $(date -u +%H:%M:%S)"
  target/deploy/latency --out /tmp/haltpoll/chain-$i --skip hop,sweep,paced,binaries --cycles 20000 --waits block > /tmp/haltpoll/chain-$i.log 2>&1
  echo "exit $? $(date -u +%H:%M:%S)"
  grep -A3 "^| chain | load | p99" /tmp/haltpoll/chain-$i/report.md | tail -2
done
