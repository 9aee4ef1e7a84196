#!/bin/bash
# Instructions per second of chosen processes in a paced run, counted by callgrind (repeatable
# whatever else the machine does, unlike CPU time): a paced 40-s `testbed run` of the default
# profile with PROCs under `valgrind --tool=callgrind`, counters zeroed 10 s in and dumped 20 s
# later. Valgrind slows them some 50x, so the run reports deadline misses and safe mode; the
# counts are of the same code paths (a tick's work), which is what is compared.
# usage: instructions.sh BINDIR OUTDIR PROC...   e.g. ... target/deploy /tmp/cg plant controller
set -u
BIN=$1; OUT=$2; shift 2
rm -rf /tmp/vgbin; mkdir -p /tmp/vgbin "$OUT"
cp "$BIN"/* /tmp/vgbin/ 2>/dev/null
for p in "$@"; do
  mv /tmp/vgbin/$p /tmp/vgbin/$p.real
  printf '#!/bin/bash\nexec valgrind --tool=callgrind --callgrind-out-file=%s/cg.%s.%%p /tmp/vgbin/%s.real "$@"\n' "$OUT" $p $p > /tmp/vgbin/$p
  chmod +x /tmp/vgbin/$p
done
( /tmp/vgbin/testbed run --paced --duration 40 --log "$OUT/run.mcap" --no-progress > "$OUT/run.out" 2>&1 & )
sleep 10
callgrind_control -z > /dev/null
t0=$(date +%s.%N)
sleep 20
callgrind_control -d > /dev/null
t1=$(date +%s.%N)
while pgrep -x testbed >/dev/null; do sleep 1; done
for p in "$@"; do
  f=$(ls "$OUT"/cg.$p.*.1)
  awk -v p=$p -v dt=$(echo "$t1 - $t0" | bc) '/^summary:/ {printf "%-18s %12d instructions in %.2f s: %9.0f a second\n", p, $2, dt, $2/dt}' "$f"
done | tee "$OUT/summary.txt"
