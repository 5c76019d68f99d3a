#!/usr/bin/env bash
# Builds, once, a small x86_64 kernel with gpio-sim from Debian's
# linux-source-6.1 into OUT_DIR/bzImage (cached: a second call returns at once).
# Usage: build-kernel.sh OUT_DIR
set -euo pipefail
out="$1"
tarball=/usr/src/linux-source-6.1.tar.xz
[ -f "$out/bzImage" ] && exit 0
mkdir -p "$out"
src="$out/linux-source-6.1"
if [ ! -f "$src/Makefile" ]; then
  echo "gpio-sim: unpacking $tarball (without the documentation and device trees)" >&2
  # Kconfig reads files of every architecture (crypto/Kconfig sources them
  # all), so only what no x86 build reads stays out.
  tar -xJf "$tarball" -C "$out" --exclude='linux-source-6.1/Documentation/*/*' \
    --exclude='linux-source-6.1/arch/*/boot/dts'
fi
cd "$src"
make -s tinyconfig
# What the guest needs: a 64-bit kernel with a serial console, an initramfs,
# devtmpfs, proc, sysfs and configfs, the GPIO character device with the
# gpio-sim driver, ELF and script binaries, and what a threaded C++ test
# program calls (futex, epoll, eventfd, timers, shared memory).
scripts/config \
  -e 64BIT -e PRINTK -e TTY -e SERIAL_8250 -e SERIAL_8250_CONSOLE \
  -e BLK_DEV_INITRD -e RD_GZIP -e DEVTMPFS -e DEVTMPFS_MOUNT -e PROC_FS -e SYSFS -e CONFIGFS_FS \
  -e GPIOLIB -e GPIO_CDEV -e GPIO_CDEV_V1 -e GPIO_SIM \
  -e BINFMT_ELF -e BINFMT_SCRIPT \
  -e FUTEX -e EPOLL -e EVENTFD -e SIGNALFD -e TIMERFD -e SHMEM -e POSIX_TIMERS -e HIGH_RES_TIMERS \
  -e MULTIUSER -e FILE_LOCKING -e SMP
make -s olddefconfig
for option in GPIO_SIM GPIO_CDEV_V1 CONFIGFS_FS SERIAL_8250_CONSOLE BLK_DEV_INITRD; do
  grep -q "^CONFIG_$option=y" .config || { echo "gpio-sim: CONFIG_$option did not stick" >&2; exit 1; }
done
echo "gpio-sim: building the kernel" >&2
make -s -j"$(nproc)" bzImage
cp arch/x86/boot/bzImage "$out/bzImage"
