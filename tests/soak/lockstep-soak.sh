#!/usr/bin/env bash
# Soak test (not in CI; 20-60 min here, 50/50 passed on 2026-11-23): RUNS lockstep runs of DURATION simulated seconds of the
# simulation profile under a CPU hog (one busy loop per core), each with its own seed. Fails on
# the first run that fails (a late record, a hang, a crash) and prints its log; at the end,
# prints how many runs passed. Two runs of each seed are not compared here (the e2e determinism
# test does that); this is about never failing under load.
#
#   cargo build --release --workspace --bins
#   tests/soak/lockstep-soak.sh [RUNS=50] [DURATION=3000]
set -euo pipefail
cd "$(dirname "$0")/../.."
runs=${1:-50}
duration=${2:-3000}
testbed=target/release/testbed
[ -x "$testbed" ] || { echo "build first: cargo build --release --workspace --bins" >&2; exit 1; }
out=$(mktemp -d /tmp/soak.XXXXXX)
hogs=()
for _ in $(seq "$(nproc)"); do (while :; do :; done) & hogs+=($!); done
trap 'kill "${hogs[@]}" 2>/dev/null; true' EXIT
passed=0
for i in $(seq "$runs"); do
    start=$(date +%s)
    # A run of 3000 s takes ~15-100 s under load; ten minutes means it is stuck.
    if timeout 600 "$testbed" run --profile simulation --duration "$duration" --seed "$i" \
        --log "$out/run.mcap" > "$out/run.out" 2> "$out/run.err"; then
        passed=$((passed + 1))
        echo "run $i/$runs: ok ($(( $(date +%s) - start )) s)"
    else
        echo "run $i/$runs (seed $i) FAILED after $(( $(date +%s) - start )) s:" >&2
        tail -30 "$out/run.err" >&2
        exit 1
    fi
done
echo "soak: $passed/$runs lockstep runs of $duration s passed under a CPU hog"
rm -rf "$out"
