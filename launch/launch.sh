#!/usr/bin/env bash
# Build the pipeline and run a launch profile: the main job of the test bed.
#
#   launch/launch.sh [PROFILE] [testbed run options...]
#
# PROFILE is a name from launch/profiles (simulation, can-sim, replay, can-replay, platform, mixed,
# vcan)
# or a path to a TOML file; default: simulation. Options go to `testbed run` (see
# `testbed run --help`), e.g. --duration 60, --seed 7, --log out/run.mcap, --paced (or
# --mode paced), --max-wall 600, --check, --config FILE, --json. The build is only what a run
# needs: the one `testbed` executable (the CLI, the launcher and every pipeline process are its
# roles), in the `deploy` profile (the release build optimised as a whole, into target/deploy/;
# see Cargo.toml), with cargo's progress shown; set TESTBED_NO_BUILD=1 to skip it. `testbed run`
# writes the run configuration beside the log and starts the launcher (`testbed-launch`), which
# starts, supervises and stops the processes; Ctrl-C stops the run and the summary of what was
# recorded is still printed.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(dirname "$here")"

profile="simulation"
if [[ $# -ge 1 && "$1" != -* ]]; then
    profile="$1"
    shift
fi

if [[ "${TESTBED_NO_BUILD:-0}" != "1" ]]; then
    (cd "$root" && cargo build --profile deploy -p testbed-cli --bin testbed)
fi

testbed="${CARGO_TARGET_DIR:-$root/target}/deploy/testbed"
if [[ ! -x "$testbed" ]]; then
    echo "launch.sh: $testbed not found (build failed?)" >&2
    exit 2
fi
cd "$root"
exec "$testbed" run --profile "$profile" "$@"
