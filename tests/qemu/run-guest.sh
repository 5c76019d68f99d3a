#!/usr/bin/env bash
# Boots a check program in a qemu guest: builds (once, cached) the small
# kernel with gpio-sim and comedi_test, packs CHECK_PROGRAM with busybox and
# the guest's INIT script into an initramfs, boots it under software
# emulation and reads the verdict off the serial console. Exits 77 (CTest:
# skipped) with the reason when qemu, busybox-static or the kernel source
# are missing.
# Usage: run-guest.sh NAME INIT CHECK_PROGRAM WORK_DIR KERNEL_DIR [KERNEL_ARGS]
# Environment, both optional:
#   GUEST_FILES  more files for the guest, each HOST_PATH=GUEST_PATH (space
#                separated), programs and modules with the libraries they load
#   GUEST_MEMORY the guest's memory (default 256M)
# What the guest writes to its second serial port (/dev/ttyS1) lands in
# WORK_DIR/ttyS1.out, for the host to check after the guest has gone.
set -euo pipefail
name="$1" init="$2" check="$3" work="$4" kernel="$5" args="${6:-}"
here="$(cd "$(dirname "$0")" && pwd)"

skip() { echo "SKIP: $*"; exit 77; }
command -v qemu-system-x86_64 >/dev/null || skip "qemu-system-x86_64 not installed (Debian: qemu-system-x86)"
[ -x /bin/busybox ] || skip "busybox not installed (Debian: busybox-static)"
[ -f /usr/src/linux-source-6.1.tar.xz ] || skip "kernel source missing (Debian: linux-source-6.1)"
for tool in make gcc bc flex bison cpio gzip flock; do
  command -v "$tool" >/dev/null || skip "$tool not installed"
done

"$here/build-kernel.sh" "$kernel"

# The initramfs: busybox, /init, the check program and the libraries it loads.
root="$work/initramfs"
rm -rf "$root"
mkdir -p "$root"/{bin,proc,sys,dev}
cp /bin/busybox "$root/bin/busybox"
for applet in sh mount mkdir cat echo reboot seq sleep ls base64 stty; do ln -s busybox "$root/bin/$applet"; done
cp "$init" "$root/init"
chmod +x "$root/init"
# A file and, for a program or a module, the libraries it loads.
add() {
  mkdir -p "$root$(dirname "$2")"
  cp -L "$1" "$root$2"
  if ldd "$1" >/dev/null 2>&1; then
    ldd "$1" | grep -o '/[^ ]*' | while read -r lib; do
      mkdir -p "$root$(dirname "$lib")"
      cp -L "$lib" "$root$lib"
    done
  fi
}
add "$check" /check
for pair in ${GUEST_FILES:-}; do add "${pair%%=*}" "${pair#*=}"; done
(cd "$root" && find . | cpio -o -H newc --quiet | gzip -1) > "$work/initramfs.cpio.gz"

accel=tcg  # software emulation: KVM may be missing or unusable in a nested machine
# Under software emulation the guest's TSC is the host's counter. Its rate,
# from the host, spares the guest a calibration against the emulated PIT,
# which fails on a loaded machine (the tiny kernel has no HPET or ACPI PM
# timer to fall back on) and leaves its clock on jiffies.
tsc_khz=$(awk -F: '/^cpu MHz/ { printf "%d", $2 * 1000; exit }' /proc/cpuinfo)
args="${tsc_khz:+tsc_early_khz=$tsc_khz }$args"
console="$work/console.txt"
# A guest whose init says "NAME: no tsc clock" found its clock on jiffies
# (the emulated TSC was not taken on a loaded machine): its timing would
# mean nothing, so it is booted again, up to three times.
for attempt in 1 2 3; do
  rm -f "$work/ttyS1.out"
  timeout 600 qemu-system-x86_64 -accel "$accel" -m "${GUEST_MEMORY:-256M}" -smp 2 -nographic \
    -no-reboot -serial mon:stdio -serial "file:$work/ttyS1.out" -kernel "$kernel/bzImage" -initrd "$work/initramfs.cpio.gz" \
    -append "console=ttyS0 panic=-1 quiet tsc=reliable $args" > "$console" 2>&1 || true
  grep -q "^$name: no tsc clock" "$console" || break
  echo "$name: boot $attempt: $(grep "^$name: no tsc clock" "$console")"
done
grep -E "^(PASS|FAIL|$name)" "$console" || { cat "$console"; }
if grep -q "^$name exit code: 0" "$console" && ! grep -q "^FAIL" "$console"; then
  echo "$name: all checks passed"
  exit 0
fi
echo "$name: checks failed (console: $console)"
exit 1
