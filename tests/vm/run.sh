#!/usr/bin/env bash
# Boot the CAN test VM, run one command in it and return its output and exit status.
#
#   tests/vm/run.sh [--scratch DIR] [--timeout SECONDS] [--mem MB] -- COMMAND [ARG...]
#
# The VM: Debian's kernel (linux-image-amd64) under KVM, an initramfs built from busybox,
# iproute2 and can-utils (tests/vm/build-initramfs.sh, cached in target/vm/), no network.
# Inside, the SocketCAN modules are loaded and vcan0 is up; the workspace is mounted read-only
# at its host path (so target/release/* and launch/profiles/* are where they are on the host)
# and DIR (default: a new temporary directory) read-write as the working directory /scratch.
# COMMAND runs under busybox sh in /scratch; its output comes back over the serial console
# (also saved as DIR/console.log) and its exit status is this script's.
#
# Exit status: the command's; 124 when the VM did not report one in time; 125 when the VM
# could not be set up; 77 when this machine cannot run it (no /dev/kvm, no qemu or kernel),
# with the reason on stderr. tests/vm/README.md has the details.
#
# Environment: TESTBED_VM_ACCEL (below), KVM_PROBE_S (how long KVM may take to boot when it is
# probed, default 60 s).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
scratch=""
timeout=300
mem=2048
while [[ $# -gt 0 ]]; do
    case "$1" in
        --scratch) scratch="$2"; shift 2 ;;
        --timeout) timeout="$2"; shift 2 ;;
        --mem) mem="$2"; shift 2 ;;
        --) shift; break ;;
        *) echo "run.sh: unknown option $1 (usage: run.sh [--scratch DIR] [--timeout S] -- COMMAND...)" >&2; exit 2 ;;
    esac
done
[[ $# -gt 0 ]] || { echo "run.sh: no command given" >&2; exit 2; }

unavailable() {
    echo "tests/vm/run.sh: cannot run the CAN test VM here: $*" >&2
    exit 77
}
# How the VM runs: TESTBED_VM_ACCEL=kvm (KVM only), tcg (QEMU's emulator: slow, any machine) or
# auto (default): KVM, or TCG with a warning where /dev/kvm exists but does not boot the
# kernel (a nested, paravirtual KVM); without /dev/kvm the VM is not started (status 77).
accel="${TESTBED_VM_ACCEL:-auto}"
case "$accel" in
    kvm | auto)
        [[ -e /dev/kvm ]] || unavailable "/dev/kvm is missing (no KVM on this machine; TESTBED_VM_ACCEL=tcg runs the VM emulated, slowly)"
        [[ -r /dev/kvm && -w /dev/kvm ]] || unavailable "/dev/kvm is not readable and writable by $(id -un)"
        ;;
    tcg) ;;
    *) echo "run.sh: TESTBED_VM_ACCEL must be kvm, tcg or auto, not $accel" >&2; exit 2 ;;
esac
command -v qemu-system-x86_64 >/dev/null || unavailable "qemu-system-x86_64 not installed (apt-get install qemu-system-x86)"
command -v busybox >/dev/null || unavailable "busybox not installed (apt-get install busybox-static)"
command -v candump >/dev/null || unavailable "can-utils not installed (apt-get install can-utils)"

# The newest kernel that has both an image and its modules.
kver=""
for image in $(ls -1 /boot/vmlinuz-* 2>/dev/null | sort -V -r); do
    v="${image#/boot/vmlinuz-}"
    if [[ -f "/lib/modules/$v/modules.dep" ]]; then kver="$v"; break; fi
done
[[ -n "$kver" ]] || unavailable "no kernel in /boot with modules in /lib/modules (apt-get install linux-image-amd64)"
kernel="/boot/vmlinuz-$kver"
[[ -r "$kernel" ]] || unavailable "$kernel is not readable by $(id -un)"

# The project's release binaries: their shared libraries go into the initramfs.
release="${CARGO_TARGET_DIR:-$root/target}/release"
bins=()
for f in "$release"/*; do
    [[ -f "$f" && -x "$f" ]] && head -c4 "$f" | grep -q 'ELF' && bins+=("$f")
done

cache="${CARGO_TARGET_DIR:-$root/target}/vm"
mkdir -p "$cache"
initrd="$cache/initramfs-$kver.cpio.gz"
# Rebuilt when the scripts change or a binary needs a library it does not hold (listed beside it).
libs_now="$(for b in "${bins[@]}"; do ldd "$b" 2>/dev/null | awk '/=> \//{print $3}'; done | sort -u)"
if [[ ! -f "$initrd" || "$here/init" -nt "$initrd" || "$here/build-initramfs.sh" -nt "$initrd" \
      || "$libs_now" != "$(cat "$initrd.libs" 2>/dev/null)" ]]; then
    "$here/build-initramfs.sh" "$kver" "$initrd" "${bins[@]}"
    printf '%s' "$libs_now" > "$initrd.libs"
fi

if [[ -z "$scratch" ]]; then
    scratch="$(mktemp -d /tmp/testbed-vm.XXXXXX)"
fi
mkdir -p "$scratch"
scratch="$(cd "$scratch" && pwd)"
# qemu ACCEL LIMIT_S: boots the VM, serial console on stdout.
qemu() {
    local cpu
    case "$1" in
        # ARCH_CAPABILITIES: some nested hosts refuse the MSR that `host` passes through.
        kvm) cpu=(-enable-kvm -cpu host,-arch-capabilities) ;;
        tcg) cpu=(-accel tcg,thread=multi -cpu max) ;;
    esac
    timeout --kill-after=10 "$2" qemu-system-x86_64 \
        "${cpu[@]}" -smp 2 -m "$mem" \
        -nographic -no-reboot -nic none \
        -kernel "$kernel" -initrd "$initrd" \
        -append "console=ttyS0 quiet loglevel=3 panic=-1 testbed.src=$root testbed.timeout=$timeout" \
        -virtfs "local,path=$root,mount_tag=src,security_model=none,readonly=on" \
        -virtfs "local,path=$scratch,mount_tag=scratch,security_model=none" \
        < /dev/null 2>&1 | tr -d '\r'
}

# auto: does KVM boot this kernel? Some hosts' KVM (e.g. a nested, paravirtual one) hangs in
# the kernel's decompressor. Probed once per kernel and machine, the answer cached.
if [[ "$accel" == auto ]]; then
    probe="$cache/kvm-boots-$kver-$(hostname)"
    if [[ ! -f "$probe" ]]; then
        echo "tests/vm/run.sh: probing whether KVM boots $kver (at most ${KVM_PROBE_S:-60} s)" >&2
        printf 'true\n' > "$scratch/vm-command.sh"
        if qemu kvm "${KVM_PROBE_S:-60}" | grep -q '^TESTBED-VM-EXIT 0$'; then echo kvm > "$probe"; else echo tcg > "$probe"; fi
    fi
    accel="$(cat "$probe")"
    if [[ "$accel" == tcg ]]; then
        echo "tests/vm/run.sh: WARNING: KVM exists but does not boot kernel $kver here (see $probe): the VM runs under QEMU's TCG emulator (slow)" >&2
    fi
fi
{
    echo "set -e"
    printf '%q ' "$@"
    echo
} > "$scratch/vm-command.sh"

console="$scratch/console.log"
start=$(date +%s.%N)
set +e
qemu "$accel" $((timeout + 120)) | tee "$console"
qemu_status=${PIPESTATUS[0]}
set -e
end=$(date +%s.%N)
status="$(sed -n 's/^TESTBED-VM-EXIT \([0-9]*\)$/\1/p' "$console" | tail -1)"
echo "tests/vm/run.sh: VM ran $(awk -v a="$start" -v b="$end" 'BEGIN{printf "%.1f", b - a}') s (qemu status $qemu_status), accel $accel, command status ${status:-none}" >&2
if [[ -z "$status" ]]; then
    echo "tests/vm/run.sh: the VM reported no exit status (timed out after ${timeout} s or crashed); console in $console" >&2
    exit 124
fi
exit "$status"
