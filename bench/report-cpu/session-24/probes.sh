#!/bin/sh
# The session-24 probes, alternated: the null pipeline of each profile's shape (30-s runs, no
# pages and 150 pages an activation), then the ring of 2, 4 and 8 processes (8 activations a
# tick, 150 pages each, three rounds). Needs gcc; about 12 minutes.
set -e
here="$(cd "$(dirname "$0")" && pwd)"
bin="$(mktemp -d)"
trap 'rm -rf "$bin"' EXIT
gcc -O2 -o "$bin/null-pipeline" "$here/null-pipeline.c"
gcc -O2 -o "$bin/address-spaces" "$here/address-spaces.c"
date -u +"start %H:%M UTC"
for round in 1 2 3; do
  for pages in 0 150; do
    for pattern in timer grouped split; do "$bin/null-pipeline" $pattern 30 $pages; done
  done
done
"$bin/address-spaces" 8 150 3
date -u +"end %H:%M UTC"
