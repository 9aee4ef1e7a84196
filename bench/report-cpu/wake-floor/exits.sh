#!/bin/bash
BIN=${1:-/tmp/base-deploy}; shift
T=/sys/kernel/tracing
cd /tmp/sys && rm -rf run3 && mkdir run3
"$@" $BIN/testbed run --profile simulation --mode paced --duration 25 --log /tmp/sys/run3/x.mcap > run3/out.txt 2>&1 &
sleep 8
echo > $T/trace; echo 40000 > $T/buffer_size_kb
for e in msr/write_msr ipi/ipi_send_cpu ipi/ipi_send_cpumask sched/sched_switch irq_vectors/reschedule_entry irq_vectors/call_function_single_entry irq_vectors/local_timer_entry power/cpu_idle; do echo 1 > $T/events/$e/enable; done
echo 1 > $T/tracing_on; sleep 5; echo 0 > $T/tracing_on
echo 0 > $T/events/enable
cat $T/trace > run3/trace.txt
wait
python3 - <<'PY'
import re,collections
c=collections.defaultdict(collections.Counter)
for line in open('/tmp/sys/run3/trace.txt'):
    m=re.match(r'\s*(.+?)-(\d+)\s+\[\d+\]\s+\S+\s+[\d.]+: (\w+): ?(.*)',line)
    if not m: continue
    comm,ev,rest=m.group(1).strip(),m.group(3),m.group(4)
    if ev=='write_msr': ev='msr '+rest.split(',')[0]
    if ev=='ipi_send_cpu': ev='ipi '+re.search(r'callsite=(\S+)',rest).group(1).split('+')[0]
    if ev=='cpu_idle': ev='idle '+('exit' if 'state=4294967295' in rest else 'enter')
    if ev=='sched_switch': ev='switch-out'
    c[comm][ev]+=1
tot=collections.Counter()
for comm in sorted(c, key=lambda k:-sum(c[k].values())):
    print(f"{comm:18s} "+", ".join(f"{k} {v/5:.1f}" for k,v in c[comm].most_common()))
    for k,v in c[comm].items(): tot[k]+=v
print("total", ", ".join(f"{k} {v/5:.1f}" for k,v in tot.most_common()))
PY
