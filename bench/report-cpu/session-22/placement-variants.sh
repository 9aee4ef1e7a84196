#!/bin/bash
# usage: placement-variants.sh BIN_DIR variant... ; each variant: default | one0 | NAME (a
# profile NAME.toml beside this script: chain0.toml is the session start's simulation profile
# with `cpus = [0]` on the tick's processes and `cpus = [1]` on the logger and ground link;
# split.toml and chain1.toml, as described in 1-placement-variants.txt, were made the same way).
# Run from the repository's root.
BIN=$1; shift
HERE=$(cd "$(dirname "$0")" && pwd)
for v in "$@"; do
  case $v in
    default) args="--profile simulation"; pre="";;
    one0) args="--profile simulation"; pre="taskset -c 0";;
    *) args="--profile $HERE/$v.toml"; pre="";;
  esac
  x=$(RUST_LOG=warn,testbed_processes::plant=info $pre $BIN/testbed run $args --duration 300 --no-progress --log /tmp/placement-variants.mcap 2>&1 >/dev/null | grep -o 'x_real_time=[0-9.]*' | cut -d= -f2)
  printf "%-8s %s\n" $v "$x"
done
