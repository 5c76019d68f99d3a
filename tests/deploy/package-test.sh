#!/usr/bin/env bash
# The Debian packages in a fresh Debian 12 root: install (with their
# dependencies, from Debian), the files in place, the system user, the unit
# file verified, piezod running from the package answering `piezo status`,
# the conffile kept over a reinstall, and clean removal and purge.
# Needs root (chroot) and debootstrap; exits 77 (CTest: skipped) saying why
# otherwise. The base root is built once and kept in CACHE_DIR (default:
# WORK_DIR); apt-get updates it inside each test.
# Usage: package-test.sh WORK_DIR DEB_DIR PORT [CACHE_DIR]
set -euo pipefail
work="$1" debs="$2" port="$3" cache="${4:-$1}"

skip() { echo "SKIP: $*"; exit 77; }
[ "$(id -u)" -eq 0 ] || skip "needs root for chroot"
command -v debootstrap >/dev/null || skip "debootstrap not installed (Debian: debootstrap)"
ls "$debs"/piezod_*.deb >/dev/null 2>&1 || skip "no piezod package in $debs (run cpack -G DEB)"

mkdir -p "$work" "$cache"
base="$cache/bookworm-minbase.tar"
(
  # One builder at a time; the tar appears whole or not at all.
  flock 9
  if [ ! -f "$base" ]; then
    echo "package-test: debootstrap --variant=minbase bookworm (once, cached in $base)"
    rm -rf "$work/base"
    debootstrap --variant=minbase bookworm "$work/base" http://deb.debian.org/debian > "$work/debootstrap.log" 2>&1 \
      || { tail -20 "$work/debootstrap.log"; exit 1; }
    tar -C "$work/base" -cf "$base.part" .
    mv "$base.part" "$base"
    rm -rf "$work/base"
  fi
) 9> "$cache/.lock"

root="$work/root"
cleanup() {
  [ -n "${daemon_pid:-}" ] && kill "$daemon_pid" 2>/dev/null || true
  umount -l "$root/proc" "$root/dev" 2>/dev/null || true
}
trap cleanup EXIT
umount -l "$root/proc" "$root/dev" 2>/dev/null || true
rm -rf "$root"
mkdir -p "$root"
tar -C "$root" -xf "$base"
cp /etc/resolv.conf "$root/etc/resolv.conf"
mount -t proc proc "$root/proc"
mount --bind /dev "$root/dev"
cp "$debs"/piezod_*.deb "$root/tmp/piezod.deb"
cp "$debs"/piezo_*.deb "$root/tmp/piezo.deb"
cp "$debs"/python3-piezo-rig_*.deb "$root/tmp/python3-piezo-rig.deb"
in_root() { chroot "$root" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin "$@"; }
fail() { echo "FAIL: $*"; exit 1; }

# The Python package is one process, one rank: it must not pull in Open MPI
# (only piezo's studies split across MPI ranks).
py_depends=$(dpkg-deb -f "$root/tmp/python3-piezo-rig.deb" Depends)
case "$py_depends" in *mpi*) fail "python3-piezo-rig depends on MPI: $py_depends" ;; esac
echo "PASS python3-piezo-rig depends on no MPI: $py_depends"

echo "package-test: apt-get install ./piezod.deb ./piezo.deb ./python3-piezo-rig.deb (their dependencies from Debian)"
in_root apt-get update -q > "$work/apt.log" 2>&1 || { tail "$work/apt.log"; exit 1; }
in_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
  /tmp/piezod.deb /tmp/piezo.deb /tmp/python3-piezo-rig.deb >> "$work/apt.log" 2>&1 || { tail -30 "$work/apt.log"; fail "install"; }

for f in /usr/bin/piezod /etc/piezod.toml /usr/lib/systemd/system/piezod.service \
         /usr/share/doc/piezod/protocol.md; do
  [ -e "$root$f" ] || fail "$f not installed"
done
echo "PASS files in place"
in_root dpkg-query -W -f='${Conffiles}\n' piezod | grep -q /etc/piezod.toml || fail "/etc/piezod.toml not a conffile"
echo "PASS /etc/piezod.toml is a conffile"
in_root getent passwd piezod >/dev/null || fail "no piezod user"
echo "PASS system user piezod: $(in_root id piezod)"
version=$(in_root piezod --version) || fail "piezod --version"
echo "PASS $version"
host_version=$(in_root piezo --version) || fail "piezo --version"
echo "PASS $host_version"
# HDF5 comes as a module, loaded when a command first writes a file: the
# installed piezo finds it where the package put it.
in_root piezo simulate --duration 0.1 --out /tmp/package-test.h5 >/dev/null ||
  fail "the installed piezo writes HDF5 (its module libpiezo_h5.so)"
[ "$(head -c 4 "$root/tmp/package-test.h5" | tail -c 3)" = HDF ] || fail "/tmp/package-test.h5 is not HDF5"
echo "PASS the installed piezo loads its HDF5 module and writes a .h5"
# The installed Python package: its model is the CLI's to the last digit.
in_root python3 -c '
import json, subprocess
from piezo_rig import model
sim = model.simulate(model.Parameters(V0=60), 0.5)
cli = json.loads(subprocess.run(["piezo", "simulate", "--json", "--set", "V0=60", "--duration", "0.5"],
                                capture_output=True, text=True, check=True).stdout)
assert sim.theta_end_rad == cli["theta_end_rad"], (sim.theta_end_rad, cli["theta_end_rad"])
print("theta_end", sim.theta_end_rad, "rad")' || fail "python3-piezo-rig: simulate against piezo simulate --json"
echo "PASS import piezo_rig from python3-piezo-rig: simulate matches piezo simulate --json"
# The Tango bridge ships in the package; PyTango is only recommended, and
# without it the program says what to install.
[ -x "$root/usr/bin/piezo-tango" ] || fail "/usr/bin/piezo-tango not installed"
tango_said=$(in_root piezo-tango lab 2>&1) && fail "piezo-tango ran without PyTango"
case "$tango_said" in *"apt-get install python3-tango"*) ;; *) fail "piezo-tango without PyTango: $tango_said" ;; esac
echo "PASS /usr/bin/piezo-tango installed; without python3-tango it says: $tango_said"
# The installed unit, verified by this machine's systemd (a minimal root has
# none); its ExecStart pointed at the installed binary inside the root.
mkdir -p "$work/unit"
sed "s|/usr/bin/piezod|$root/usr/bin/piezod|" "$root/usr/lib/systemd/system/piezod.service" \
  > "$work/unit/piezod.service"
systemd-analyze verify --man=no "$work/unit/piezod.service" || fail "systemd-analyze verify"
echo "PASS systemd-analyze verify piezod.service (Type=notify, WatchdogSec, limits)"

# The unit's command, as its user: the packaged daemon on the packaged config.
chroot --userspec=piezod:piezod "$root" /usr/bin/piezod --config /etc/piezod.toml \
  --listen "tcp://127.0.0.1:$port" > "$work/piezod.log" 2>&1 &
daemon_pid=$!
state=""
for _ in $(seq 1 50); do
  state=$(in_root piezo status --rig "tcp://127.0.0.1:$port" --json 2>/dev/null | \
    python3 -c 'import json,sys; print(json.load(sys.stdin)["state"])' 2>/dev/null) && break
  sleep 0.2
done
[ "$state" = idle ] || { cat "$work/piezod.log"; fail "piezo status against the packaged piezod: '$state'"; }
echo "PASS the packaged piezod, run as piezod, answers the packaged piezo status: $state"
in_root python3 -c "
from piezo_rig.board import Board, PROTOCOL
with Board('tcp://127.0.0.1:$port') as b:
    assert b.hello()['protocol'] == PROTOCOL and b.status()['state'] == 'idle'
" || fail "piezo_rig.board against the packaged piezod"
echo "PASS piezo_rig.board talks to the packaged piezod"
kill -TERM "$daemon_pid"; wait "$daemon_pid" || fail "piezod exit on SIGTERM"
daemon_pid=""

echo "# a researcher's edit" >> "$root/etc/piezod.toml"
in_root env DEBIAN_FRONTEND=noninteractive dpkg -i --force-confold /tmp/piezod.deb > /dev/null
grep -q "a researcher's edit" "$root/etc/piezod.toml" || fail "reinstall overwrote the edited config"
echo "PASS an edited /etc/piezod.toml survives a reinstall"

in_root dpkg -r python3-piezo-rig > /dev/null
[ ! -e "$root/usr/lib/python3/dist-packages/piezo_rig" ] || fail "dpkg -r left piezo_rig"
in_root dpkg -r piezo > /dev/null
[ ! -e "$root/usr/bin/piezo" ] || fail "dpkg -r left /usr/bin/piezo"
in_root dpkg -r piezod > /dev/null
[ ! -e "$root/usr/bin/piezod" ] || fail "dpkg -r left /usr/bin/piezod"
[ -e "$root/etc/piezod.toml" ] || fail "dpkg -r removed the conffile (only purge may)"
in_root dpkg -P piezod > /dev/null
[ ! -e "$root/etc/piezod.toml" ] || fail "dpkg -P left /etc/piezod.toml"
! in_root getent passwd piezod >/dev/null || fail "purge left the piezod user"
echo "PASS dpkg -r removes the program, dpkg -P the config and the user"
echo "package-test: all checks passed"
