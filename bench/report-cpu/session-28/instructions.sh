#!/bin/bash
# Instructions of chosen processes, counted by callgrind (repeatable whatever else the machine
# does, unlike CPU time), in a `testbed run` of the default profile with PROCs under
# `valgrind --tool=callgrind`:
#   paced:    a paced 40-s run, counters zeroed 10 s in and dumped 20 s later; instructions a
#             second. Valgrind slows the processes some 50x, so the run misses deadlines and
#             may enter safe mode; the counts are of the same code paths, which is what is
#             compared.
#   lockstep: lockstep runs of 10 s and 150 s of simulated time (seed 7); (long - short) / 1400
#             ticks is the count a tick without start-up and shutdown.
# usage: instructions.sh paced|lockstep BINDIR OUTDIR PROC...
set -u
MODE=$1; BIN=$2; OUT=$3; shift 3
rm -rf /tmp/vgbin; mkdir -p /tmp/vgbin "$OUT"
cp "$BIN"/* /tmp/vgbin/ 2>/dev/null
for p in "$@"; do
  mv /tmp/vgbin/$p /tmp/vgbin/$p.real
  printf '#!/bin/bash\nexec valgrind --tool=callgrind --callgrind-out-file=%s/cg.%s.${TESTBED_CG_RUN:-paced}.%%p /tmp/vgbin/%s.real "$@"\n' "$OUT" $p $p > /tmp/vgbin/$p
  chmod +x /tmp/vgbin/$p
done
count() { awk '/^summary:/ {print $2}' "$OUT"/cg.$1.$2.*; }
case $MODE in
paced)
  ( /tmp/vgbin/testbed run --paced --duration 40 --log "$OUT/run.mcap" --no-progress > "$OUT/run.out" 2>&1 & )
  sleep 10
  callgrind_control -z > /dev/null
  t0=$(date +%s.%N)
  sleep 20
  callgrind_control -d > /dev/null
  t1=$(date +%s.%N)
  while pgrep -x testbed >/dev/null; do sleep 1; done
  for p in "$@"; do
    # the dump after zeroing is the second part (file suffix .1)
    f=$(ls "$OUT"/cg.$p.paced.*.1)
    awk -v p=$p -v dt=$(echo "$t1 - $t0" | bc) '/^summary:/ {printf "%-18s %12d instructions in %.2f s: %9.0f a second\n", p, $2, dt, $2/dt}' "$f"
  done ;;
lockstep)
  for d in 10 150; do
    TESTBED_CG_RUN=$d timeout 900 /tmp/vgbin/testbed run --duration $d --seed 7 --max-wall 900 --log "$OUT/run$d.mcap" --no-progress > "$OUT/run$d.out" 2>&1 \
      || echo "run of $d s failed: $(tail -1 "$OUT/run$d.out")"
  done
  for p in "$@"; do
    echo "$p $(count $p 10) $(count $p 150)" | awk '{printf "%-18s %10.0f instructions a tick (%d in 10 s, %d in 150 s)\n", $1, ($3-$2)/1400, $2, $3}'
  done ;;
*) echo "usage: instructions.sh paced|lockstep BINDIR OUTDIR PROC..." >&2; exit 2 ;;
esac | tee "$OUT/summary.txt"
