#!/usr/bin/env bash
# Installs what piezo-rig needs from Debian 12 (apt-get, as root or via sudo)
# and the npm registry (uPlot, for the web view), and builds it.
# Usage: scripts/setup.sh [preset] [--gpio-sim] [--arm64] [--peers]
# (default preset: default; --gpio-sim adds what the gpio-sim test needs:
# qemu, busybox-static, the kernel source and its build tools; --arm64, or
# the preset arm64, adds Debian's arm64 cross toolchain, the :arm64 -dev
# packages (dpkg --add-architecture arm64) and qemu-user, and builds the
# board build in build/arm64 as well; --peers adds SciPy, GNU Octave and
# numba, which only tests/bench/bench_peers.py uses)
set -euo pipefail
cd "$(dirname "$0")/.."
preset="default"
gpio_sim=""
arm64=""
peers=""
for arg in "$@"; do
  case "$arg" in
    --gpio-sim) gpio_sim=yes ;;
    --arm64) arm64=yes ;;
    --peers) peers=yes ;;
    -*) echo "setup: unknown option $arg" >&2; exit 2 ;;
    *) preset="$arg" ;;
  esac
done
[ "$preset" = arm64 ] && arm64=yes

packages=(
  build-essential cmake ninja-build ccache pkg-config git file
  libeigen3-dev libcli11-dev libtomlplusplus-dev libfmt-dev nlohmann-json3-dev
  libhdf5-dev zlib1g-dev libgtest-dev libgmock-dev
  gnuplot-nox python3 python3-h5py python3-numpy
  rt-tests libgpiod-dev libmodbus-dev libcomedi-dev mbpoll socat python3-pymodbus python3-serial-asyncio
  libzmq3-dev cppzmq-dev python3-zmq python3-msgpack clang libclang-rt-14-dev
  libsystemd-dev systemd debootstrap iproute2 libboost-dev python3-openturns libopenmpi-dev openmpi-bin
  libsundials-dev
  libcpp-httplib-dev chromium chromium-driver python3-selenium fonts-dejavu-core
  pybind11-dev python3-dev python3-pandas python3-pytest python3-matplotlib mypy
  python3-nbclient python3-nbformat python3-ipykernel python3-tango mariadb-server tango-db
)
if [ -n "$peers" ]; then packages+=(python3-scipy octave python3-numba); fi
# The web view's plots (uPlot) come from the npm registry; npm from Debian
# unless a Node.js install already brings its own.
command -v npm > /dev/null || packages+=(npm)
if [ -n "$arm64" ]; then
  packages+=(g++-aarch64-linux-gnu qemu-user)
  for p in libzmq3-dev cppzmq-dev libmodbus-dev libgpiod-dev libfmt-dev libgtest-dev \
           libtomlplusplus-dev libsystemd-dev; do
    packages+=("$p:arm64")
  done
fi
if [ -n "$gpio_sim" ]; then
  packages+=(qemu-system-x86 busybox-static linux-source-6.1 bc flex bison libelf-dev cpio xz-utils)
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
sudo_cmd=()
[ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
if [ -n "$arm64" ] && ! dpkg --print-foreign-architectures | grep -qx arm64; then
  echo "setup: dpkg --add-architecture arm64"
  "${sudo_cmd[@]}" dpkg --add-architecture arm64
fi
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  "${sudo_cmd[@]}" apt-get update -q
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# The loopback names every installed Debian has in /etc/hosts and a bare
# debootstrap root lacks: the browser test's webdriver, and anyone's
# tcp://localhost, look them up.
if ! getent hosts localhost > /dev/null; then
  echo "setup: /etc/hosts has no localhost; adding the loopback entries a Debian install writes"
  printf '127.0.0.1\tlocalhost\n::1\t\tlocalhost ip6-localhost ip6-loopback\n' |
    "${sudo_cmd[@]}" tee -a /etc/hosts > /dev/null
fi

# comedilib for the board: Debian's libcomedi-dev cannot be installed for
# two architectures at once, so its arm64 static library is taken from the
# arm64 package and put where the cross build's pkg-config looks (static:
# the board's piezod then needs no comedilib package of its own).
arm64_lib=/usr/lib/aarch64-linux-gnu
if [ -n "$arm64" ] && [ ! -f "$arm64_lib/libcomedi.a" ]; then
  echo "setup: comedilib for arm64, from libcomedi-dev:arm64"
  unpacked="$(mktemp -d)"
  (cd "$unpacked" && apt-get download -q libcomedi-dev:arm64 && dpkg -x libcomedi-dev_*_arm64.deb root)
  "${sudo_cmd[@]}" install -m 644 "$unpacked/root/usr/lib/libcomedi.a" "$arm64_lib/libcomedi.a"
  printf '%s\n' "libdir=$arm64_lib" "includedir=/usr/include" "" "Name: Comedilib" \
    "Description: Comedi Library (static, for the board)" "Version: 0.11.0" \
    "Libs: -L\${libdir} -lcomedi -lm" "Cflags: -I\${includedir}" |
    "${sudo_cmd[@]}" tee "$arm64_lib/pkgconfig/comedilib.pc" > /dev/null
  rm -rf "$unpacked"
fi

uplot_version=1.6.32
if [ ! -f build/web-vendor/node_modules/uplot/dist/uPlot.iife.min.js ]; then
  echo "setup: npm install uplot@$uplot_version (the web view's plots)"
  npm install --prefix build/web-vendor "uplot@$uplot_version" --no-audit --no-fund --loglevel=error
fi

if [ -n "$arm64" ] && [ "$preset" != arm64 ]; then
  cmake --preset arm64 >/dev/null
  cmake --build --preset arm64 -j "$(nproc)"
fi
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset" -j "$(nproc)"
