#!/usr/bin/env bash
# Installs what piezo-rig needs from Debian 12 (apt-get, as root or via sudo)
# and builds it. Usage: scripts/setup.sh [preset] [--gpio-sim]
# (default preset: default; --gpio-sim adds what the gpio-sim test needs:
# qemu, busybox-static, the kernel source and its build tools)
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-default}"
gpio_sim="${2:-}"

packages=(
  build-essential cmake pkg-config git
  libeigen3-dev libcli11-dev libtomlplusplus-dev libfmt-dev nlohmann-json3-dev
  libhdf5-dev libgtest-dev libgmock-dev
  gnuplot-nox python3 python3-h5py python3-numpy
  rt-tests libgpiod-dev libmodbus-dev mbpoll socat python3-pymodbus python3-serial-asyncio
  libzmq3-dev cppzmq-dev python3-zmq python3-msgpack clang libclang-rt-14-dev
)
if [ "$gpio_sim" = "--gpio-sim" ]; then
  packages+=(qemu-system-x86 busybox-static linux-source-6.1 bc flex bison libelf-dev cpio xz-utils)
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  sudo_cmd=()
  [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -q
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset" -j "$(nproc)"
