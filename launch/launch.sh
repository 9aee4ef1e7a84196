#!/usr/bin/env bash
# Build the pipeline binaries and run the launcher with a profile.
#
#   launch/launch.sh [--release] PROFILE [testbed-launch options...]
#
# PROFILE is a name from launch/profiles (simulation, platform, mixed) or a path to a TOML file.
# Options after it go to testbed-launch (see `testbed-launch --help`), e.g. --seed 7,
# --duration-s 60, --mode paced, --check. Set TESTBED_NO_BUILD=1 to skip the build.
# RUST_LOG (default info) is passed to every process.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(dirname "$here")"

build_profile=debug
cargo_flags=()
if [[ "${1:-}" == "--release" ]]; then
    build_profile=release
    cargo_flags=(--release)
    shift
fi
if [[ $# -lt 1 ]]; then
    sed -n '2,9p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2
    exit 2
fi

profile="$1"
shift
if [[ ! -f "$profile" ]]; then
    if [[ -f "$here/profiles/$profile.toml" ]]; then
        profile="$here/profiles/$profile.toml"
    else
        echo "launch.sh: no profile '$profile' (neither a file nor launch/profiles/$profile.toml)" >&2
        exit 2
    fi
fi

if [[ "${TESTBED_NO_BUILD:-0}" != "1" ]]; then
    (cd "$root" && cargo build --quiet --workspace --bins "${cargo_flags[@]}")
fi

target_dir="${CARGO_TARGET_DIR:-$root/target}"
launcher="$target_dir/$build_profile/testbed-launch"
if [[ ! -x "$launcher" ]]; then
    echo "launch.sh: $launcher not found (build failed?)" >&2
    exit 2
fi
export RUST_LOG="${RUST_LOG:-info}"
# exec: the launcher becomes this process, so Ctrl-C and kill reach it directly.
exec "$launcher" "$profile" "$@"
