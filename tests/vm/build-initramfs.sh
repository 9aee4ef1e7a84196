#!/usr/bin/env bash
# Build the initramfs of the CAN test VM (see tests/vm/README.md): busybox, iproute2's `ip`,
# can-utils, the shared libraries they and the project's binaries need, the kernel modules of
# SocketCAN (can, can-raw, vcan), 9p (the shared directories) and virtio, and tests/vm/init.
#
#   tests/vm/build-initramfs.sh KERNEL_VERSION OUTPUT.cpio.gz [BINARY...]
#
# The project's binaries themselves stay on the host (the workspace is shared read-only): only
# their shared libraries (ldd) are packed, so a rebuild of the project needs no new initramfs.
set -euo pipefail

kver="$1"
out="$2"
shift 2
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
moddir="/lib/modules/$kver"
[[ -d "$moddir" ]] || { echo "build-initramfs: no modules for kernel $kver in $moddir" >&2; exit 1; }

stage="$(mktemp -d)"
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage"/{bin,sbin,usr/bin,usr/sbin,lib,lib64,proc,sys,dev,tmp,run,modules,etc,mnt}

busybox="$(command -v busybox)"
cp "$busybox" "$stage/bin/busybox"
for applet in $("$busybox" --list); do
    [[ -e "$stage/bin/$applet" ]] || ln -s busybox "$stage/bin/$applet"
done

# Tools taken from the host with their libraries: the full `ip` (busybox's cannot create a vcan
# link or show CAN details) and can-utils.
tools=(ip candump cangen cansend canbusload)
libs=()
copy_with_libs() {
    local path="$1" dest="$2"
    mkdir -p "$(dirname "$stage/$dest")"
    cp -L "$path" "$stage/$dest"
    libs+=("$path")
}
for tool in "${tools[@]}"; do
    path="$(command -v "$tool")" || { echo "build-initramfs: $tool not found (apt-get install iproute2 can-utils)" >&2; exit 1; }
    rm -f "$stage/bin/$tool"
    copy_with_libs "$path" "usr/bin/$tool"
done
for bin in "$@"; do libs+=("$bin"); done

# Every shared library (and the dynamic loader) the tools and the project's binaries load,
# at the path the binaries expect.
for bin in "${libs[@]}"; do
    ldd "$bin" 2>/dev/null | awk '/=> \//{print $3} $1 ~ /^\//{print $1}'
done | sort -u | while read -r lib; do
    mkdir -p "$stage$(dirname "$lib")"
    cp -L "$lib" "$stage$lib"
done

# Kernel modules and their dependencies (modules.dep), in load order, decompressed: busybox
# insmod reads plain .ko files only.
wanted=(can can-raw vcan 9pnet_virtio 9p virtio_pci)
declare -A seen=()
order=()
resolve() {
    local rel="$1" dep
    [[ -n "${seen[$rel]:-}" ]] && return
    seen[$rel]=1
    for dep in $(awk -v m="$rel:" '$1 == m {for (i = 2; i <= NF; i++) print $i}' "$moddir/modules.dep"); do
        resolve "$dep"
    done
    order+=("$rel")
}
for name in "${wanted[@]}"; do
    rel="$(awk -F: -v n="$name" '{f = $1; sub(/.*\//, "", f); sub(/\.ko(\.xz|\.zst|\.gz)?$/, "", f); gsub(/_/, "-", f); m = n; gsub(/_/, "-", m); if (f == m) {print $1; exit}}' "$moddir/modules.dep")"
    [[ -n "$rel" ]] || { echo "build-initramfs: module $name not in $moddir/modules.dep" >&2; exit 1; }
    resolve "$rel"
done
: > "$stage/modules/order"
for rel in "${order[@]}"; do
    base="$(basename "$rel")"
    plain="${base%.xz}"; plain="${plain%.zst}"; plain="${plain%.gz}"
    case "$base" in
        *.xz) xz -dc "$moddir/$rel" > "$stage/modules/$plain" ;;
        *.zst) zstd -qdc "$moddir/$rel" > "$stage/modules/$plain" ;;
        *.gz) gzip -dc "$moddir/$rel" > "$stage/modules/$plain" ;;
        *) cp "$moddir/$rel" "$stage/modules/$plain" ;;
    esac
    echo "$plain" >> "$stage/modules/order"
done

cp "$here/init" "$stage/init"
chmod +x "$stage/init"
echo "root:x:0:0:root:/root:/bin/sh" > "$stage/etc/passwd"
echo "root:x:0:" > "$stage/etc/group"

tmp="$out.tmp.$$"
(cd "$stage" && find . | cpio -o -H newc --quiet | gzip -1) > "$tmp"
mv "$tmp" "$out"
