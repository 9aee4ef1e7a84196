#!/bin/bash
# The probes of results-probes.txt (session 20): what a system call, a futex ring, a chain of
# rings and a cold page cost on this machine. Needs gcc; run on an otherwise idle machine.
set -e
cd "$(dirname "$0")"
out=$(mktemp -d)
for p in syscall futex_ring ring_chain pages; do gcc -O2 -o "$out/$p" "$p.c"; done
echo "## syscall"; "$out/syscall"
echo "## futex_ring: CPU of the ringer per FUTEX_WAKE (one CPU, one CPU with the waiter SCHED_BATCH, unplaced, unplaced batch)"
taskset -c 1 "$out/futex_ring" 30; taskset -c 1 "$out/futex_ring" 30 batch; "$out/futex_ring" 30; "$out/futex_ring" 30 batch
echo "## ring_chain on one CPU (n processes, 200 rounds, 20 pages), then unplaced"
for n in 2 3 4 5 6 8 10; do taskset -c 1 "$out/ring_chain" $n 200 20; done
for n in 2 4 8; do "$out/ring_chain" $n 200 20; done
echo "## pages: 256 reads after each 100-ms sleep, 4-KiB pages then huge pages, twelve processes at once"
for i in $(seq 12); do "$out/pages" 256 0 4160 & done; wait
for i in $(seq 12); do "$out/pages" 256 1 4160 & done; wait
rm -rf "$out" /dev/shm/fwtest
