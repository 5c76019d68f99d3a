#!/usr/bin/env bash
# Builds, once, the small x86_64 kernel the qemu guests boot, from Debian's
# linux-source-6.1, into OUT_DIR/bzImage: gpio-sim (simulated GPIO chips) and
# comedi_test (a simulated DAQ card) built in. Cached: a second call with the
# same options and the same source package returns at once (OUT_DIR lies
# outside the build tree: a clean clone boots the kernel an earlier one
# built); concurrent calls wait for the first.
# Usage: build-kernel.sh OUT_DIR
set -euo pipefail
out="$1"
tarball=/usr/src/linux-source-6.1.tar.xz
# What the guests need: a 64-bit kernel with a serial console, an initramfs,
# devtmpfs, proc, sysfs, configfs and tmpfs (with its free space, which a
# run log checks before it grows), the GPIO character device with the
# gpio-sim driver, Comedi with its test driver and its parallel-port driver
# (digital I/O on qemu's emulated port), ELF and script binaries, and
# what a threaded C++ test program calls (futex, epoll, eventfd, timers,
# shared memory).
options=(64BIT PRINTK TTY SERIAL_8250 SERIAL_8250_CONSOLE
  BLK_DEV_INITRD RD_GZIP DEVTMPFS DEVTMPFS_MOUNT PROC_FS SYSFS CONFIGFS_FS TMPFS
  GPIOLIB GPIO_CDEV GPIO_CDEV_V1 GPIO_SIM
  COMEDI COMEDI_MISC_DRIVERS COMEDI_TEST COMEDI_PARPORT
  BINFMT_ELF BINFMT_SCRIPT
  FUTEX EPOLL EVENTFD SIGNALFD TIMERFD SHMEM POSIX_TIMERS HIGH_RES_TIMERS
  MULTIUSER FILE_LOCKING SMP)
# The source package's version and the compiler are part of the key.
source_id="$(dpkg-query -W -f '${Version}' linux-source-6.1 2>/dev/null || stat -c %Y "$tarball"), $(gcc -dumpfullversion)"
stamp="$source_id: ${options[*]}"
mkdir -p "$out"
exec 9> "$out/.lock"
flock 9
if [ -f "$out/bzImage" ] && [ "$(cat "$out/options" 2>/dev/null)" = "$stamp" ]; then exit 0; fi
src="$out/linux-source-6.1"
if [ "$(cat "$out/source" 2>/dev/null)" != "$source_id" ]; then rm -rf "$src"; fi
if [ ! -f "$src/Makefile" ]; then
  echo "qemu kernel: unpacking $tarball (without the documentation and device trees)" >&2
  # Kconfig reads files of every architecture (crypto/Kconfig sources them
  # all), so only what no x86 build reads stays out.
  tar -xJf "$tarball" -C "$out" --exclude='linux-source-6.1/Documentation/*/*' \
    --exclude='linux-source-6.1/arch/*/boot/dts'
  echo "$source_id" > "$out/source"
fi
cd "$src"
make -s tinyconfig
config=()
for option in "${options[@]}"; do config+=(-e "$option"); done
scripts/config "${config[@]}"
make -s olddefconfig
for option in GPIO_SIM GPIO_CDEV_V1 CONFIGFS_FS SERIAL_8250_CONSOLE BLK_DEV_INITRD COMEDI_TEST \
  COMEDI_PARPORT TMPFS; do
  grep -q "^CONFIG_$option=y" .config || { echo "qemu kernel: CONFIG_$option did not stick" >&2; exit 1; }
done
echo "qemu kernel: building" >&2
make -s -j"$(nproc)" bzImage
cp arch/x86/boot/bzImage "$out/bzImage"
echo "$stamp" > "$out/options"
