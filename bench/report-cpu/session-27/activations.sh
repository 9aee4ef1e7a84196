#!/bin/bash
# usage: acts.sh BINDIR LOGDIR ; paced run, activations and CPU per process from 8 s to 28 s
BIN=$1; D=$2; mkdir -p $D
( $BIN/testbed run --paced --duration 40 --log $D/run.mcap --no-progress > $D/run.out 2>&1 & )
sleep 8
snap() { for p in $(pgrep -x 'plant|sim-gyro|sim-wheels|sim-cmg|sim-inclinomete|sim-magnetomete|estimator|controller|logger|ground-link|testbed-launch|testbed'); do echo "$p $(cat /proc/$p/comm) $(grep ctxt /proc/$p/status | awk '{print $2}' | tr '\n' ' ') $(awk '{print $1}' /proc/$p/schedstat)"; done | sort; }
snap > $D/a.txt; sleep 20; snap > $D/b.txt
join $D/a.txt $D/b.txt | awk '{printf "%-16s vol/s %.2f invol/s %.2f cpu%% %.4f us/act %.1f\n", $2, ($7-$3)/20, ($8-$4)/20, ($9-$5)/20e9*100, ($9-$5)/1000/($7-$3); s+=($9-$5)/20e9*100; v+=($7-$3)/20} END {printf "all cpu%% %.4f vol/s %.1f\n", s, v}'
while pgrep -x testbed >/dev/null; do sleep 1; done
