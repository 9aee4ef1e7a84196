#!/bin/bash
# Instructions a tick of chosen processes, counted by callgrind (repeatable whatever else the
# machine does): two lockstep `testbed run`s of the default profile, 10 s and 150 s of simulated
# time, with PROCs under `valgrind --tool=callgrind`; (count of the long run - count of the short
# run) / 1400 ticks leaves out start-up and shutdown. Lockstep does the same work every run (same
# seed), so the counts compare builds, not the host's timing.
# usage: instructions-lockstep.sh BINDIR OUTDIR PROC...
set -u
BIN=$1; OUT=$2; shift 2
rm -rf /tmp/vgbin; mkdir -p /tmp/vgbin "$OUT"
cp "$BIN"/* /tmp/vgbin/ 2>/dev/null
for p in "$@"; do
  mv /tmp/vgbin/$p /tmp/vgbin/$p.real
  printf '#!/bin/bash\nexec valgrind --tool=callgrind --callgrind-out-file=%s/cg.%s.$TESTBED_CG_RUN.%%p /tmp/vgbin/%s.real "$@"\n' "$OUT" $p $p > /tmp/vgbin/$p
  chmod +x /tmp/vgbin/$p
done
for d in 10 150; do
  TESTBED_CG_RUN=$d timeout 900 /tmp/vgbin/testbed run --duration $d --seed 7 --max-wall 900 --log "$OUT/run$d.mcap" --no-progress > "$OUT/run$d.out" 2>&1 \
    || echo "run of $d s failed: $(tail -1 "$OUT/run$d.out")"
done
for p in "$@"; do
  short=$(awk '/^summary:/ {print $2}' "$OUT"/cg.$p.10.*)
  long=$(awk '/^summary:/ {print $2}' "$OUT"/cg.$p.150.*)
  echo "$p $short $long" | awk '{printf "%-18s %10.0f instructions a tick (%d in 10 s, %d in 150 s)\n", $1, ($3-$2)/1400, $2, $3}'
done | tee "$OUT/summary.txt"
