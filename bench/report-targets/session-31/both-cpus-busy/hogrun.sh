#!/bin/bash
# usage: hogrun.sh "cpus of hogs" tag [testbed args...]
cpus=$1; tag=$2; shift 2
pids=""
for c in $cpus; do taskset -c $c sh -c 'while :; do :; done' & pids="$pids $!"; done
sleep 0.5
s0=$(awk '/^cpu /{print $9}' /proc/stat)
timeout 90 /work/main/target/deploy/testbed run --profile simulation --paced --duration 30 --json --no-progress --log /tmp/slice/$tag.mcap "$@" > /tmp/slice/$tag.json 2>/tmp/slice/$tag.err
s1=$(awk '/^cpu /{print $9}' /proc/stat)
kill $pids
python3 -c "
import json; d=json.load(open('/tmp/slice/$tag.json')); print('$tag', 'hogs on [$cpus]', 'misses', d['deadline_misses'], 'inputs lost', d['health']['inputs_lost'], 'steal ticks', $s1-$s0)"
