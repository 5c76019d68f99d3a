#!/usr/bin/env bash
# The README's Quick start on a fresh machine: a bare Debian 12 root
# (debootstrap --variant=minbase), a clone of this repository's HEAD in it,
# and the README's two commands run one after the other from a login shell
# with a plain environment (HOME, PATH, TERM: nothing this machine sets for
# Python, pip or a compiler cache). Run before a release, not in every CI
# run: it installs every package and builds everything from nothing (about
# two hours on two cores; docs/testing.md has the last figures).
#
# Needs root (chroot, mounts) and debootstrap. Each command's output goes to
# WORK_DIR/main-job.log and WORK_DIR/test-all.log; the last lines say how
# long each took and how it ended. Exit status: 0 when both commands exit 0.
# `--again` reuses the root an earlier run left in WORK_DIR (its packages
# and compiler cache) with the clone brought to HEAD: a quicker re-check of
# a change, not a fresh machine.
# Usage: tests/deploy/fresh-machine.sh WORK_DIR [--again]
set -euo pipefail
work="$(realpath -m "${1:?usage: fresh-machine.sh WORK_DIR [--again]}")"
again="${2:-}"
repo="$(cd "$(dirname "$0")/../.." && pwd)"

[ "$(id -u)" -eq 0 ] || { echo "fresh-machine: needs root (chroot)" >&2; exit 2; }
command -v debootstrap > /dev/null ||
  { echo "fresh-machine: needs debootstrap (apt-get install debootstrap)" >&2; exit 2; }

root="$work/root"
# The root bound on itself first: `ip netns exec` (the link-cut test) needs
# the root to be a mount point, as an installed system's is.
mounts=("" proc sys dev dev/pts run tmp)
unmount() {
  local m
  for ((i = ${#mounts[@]} - 1; i >= 0; i--)); do
    m="$root/${mounts[i]}"
    mountpoint -q "$m" && umount -l "$m"
  done
  return 0
}
trap unmount EXIT
mkdir -p "$work"
unmount
# Never remove through a mount (a bound /dev is the machine's own).
if grep -q " $root[/ ]" /proc/mounts; then
  echo "fresh-machine: $root still has mounts; unmount them first" >&2
  exit 1
fi
if [ "$again" = --again ] && [ -d "$root/root/piezo-rig/.git" ]; then
  echo "fresh-machine: again in the root of an earlier run, the clone at HEAD"
else
  rm -rf --one-file-system "$root"
  echo "fresh-machine: debootstrap --variant=minbase bookworm"
  debootstrap --variant=minbase bookworm "$root" http://deb.debian.org/debian \
    > "$work/debootstrap.log" 2>&1 || { tail -20 "$work/debootstrap.log"; exit 1; }
  again=""
fi
cp /etc/resolv.conf "$root/etc/resolv.conf"
mount --bind "$root" "$root"
mount -t proc proc "$root/proc"
mount --rbind /sys "$root/sys"
mount --rbind /dev "$root/dev"
mount -t devpts -o newinstance devpts "$root/dev/pts" 2> /dev/null || true
mount -t tmpfs tmpfs "$root/run"
mount -t tmpfs -o mode=1777 tmpfs "$root/tmp"

# The clone sits where a user would have it, with the shared folder that CI
# lays beside the repository when this machine has one.
if [ -n "$again" ]; then
  git -C "$root/root/piezo-rig" fetch -q "$repo" HEAD
  git -C "$root/root/piezo-rig" reset -q --hard FETCH_HEAD
  git -C "$root/root/piezo-rig" clean -q -fdx -e build/
else
  git clone -q --no-hardlinks "$repo" "$root/root/piezo-rig"
  [ -d "$repo/../shared" ] && cp -r "$repo/../shared" "$root/root/shared"
fi

# A registry reached through this machine's own certificate authority needs
# its bundle inside the root too (Node.js reads no system store of its own).
pass=()
if [ -n "${NODE_EXTRA_CA_CERTS:-}" ] && [ -f "$NODE_EXTRA_CA_CERTS" ]; then
  cp "$NODE_EXTRA_CA_CERTS" "$root/etc/registry-ca.crt"
  pass+=(NODE_EXTRA_CA_CERTS=/etc/registry-ca.crt)
fi

# in_root COMMAND: the README's command in the clone, from a login shell.
in_root() {
  chroot "$root" /usr/bin/env -i HOME=/root TERM=dumb \
    PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin "${pass[@]}" \
    /bin/bash -lc "cd /root/piezo-rig && $1"
}

results=()
status=0
for command in scripts/main-job.sh scripts/test-all.sh; do
  name=$(basename "$command" .sh)
  echo "fresh-machine: $command (output in $work/$name.log)"
  start=$SECONDS
  rc=0
  in_root "$command" > "$work/$name.log" 2>&1 < /dev/null || rc=$?
  results+=("$(printf '%-22s exit %d after %dm%02ds' "$command" "$rc" \
    $(((SECONDS - start) / 60)) $(((SECONDS - start) % 60)))")
  ((rc == 0)) || { status=1; tail -30 "$work/$name.log"; }
done
echo "fresh-machine: Debian $(cat "$root/etc/debian_version"), commit $(git -C "$root/root/piezo-rig" rev-parse --short HEAD)"
printf 'fresh-machine: %s\n' "${results[@]}"
exit $status
