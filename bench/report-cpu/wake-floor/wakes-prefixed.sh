#!/bin/bash
# Wake-ups and CPU per process over 15 s of a paced 30-s simulation run (from 8 s in), read from
# /proc/<pid>/task/*/status (voluntary_ctxt_switches) and schedstat. BIN: the directory of the
# binaries, absolute (the processes are found by the path the launcher starts them from);
# default this clone's target/deploy.
cd /work/main
BIN=${BIN:-$PWD/target/deploy}
$PREFIX $BIN/testbed run --profile simulation --mode paced --duration 30 > /tmp/wakes-run.log 2>&1 &
sleep 8
snap() { for p in $(pgrep -f "^$BIN/"); do c=$(cat /proc/$p/comm); v=0; r=0; for t in /proc/$p/task/*; do v=$((v+$(awk '/^voluntary_ctxt/{print $2}' $t/status))); r=$((r+$(awk '{print $1}' $t/schedstat))); done; echo "$p $c $v $r"; done; }
snap > /tmp/w1; sleep 15; snap > /tmp/w2
join <(sort /tmp/w1) <(sort /tmp/w2) | awk '{printf "%-18s wakes/s %5.1f  cpu%% %.3f  us/wake %4.0f\n", $2, ($6-$3)/15, ($7-$4)/15e9*100, ($7-$4)/1e3/($6-$3+0.001); w+=($6-$3)/15; c+=($7-$4)/15e9*100} END {printf "%-18s wakes/s %5.1f  cpu%% %.3f\n", "all", w, c}'
wait
