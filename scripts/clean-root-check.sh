#!/usr/bin/env bash
# Proves the README's two commands work on a fresh Debian 12 machine: builds a clean bookworm root
# with mmdebstrap (minbase: apt and the essentials, nothing lancer needs), copies the repository's
# committed tree into it (git archive HEAD: what a clone has, no build/, no local files) and runs
# `scripts/setup.sh` then `scripts/test.sh` inside it, as root, in a chroot with /proc, /dev and
# /sys mounted. Run it once per change to the install steps (scripts/deps.sh, setup.sh, test.sh,
# CMake's find_package lines); it downloads the packages and builds from nothing, so it takes tens
# of minutes, and is not part of every CI run.
#
#   sudo scripts/clean-root-check.sh [--quick] [--keep] [--root DIR]
#     --quick   passes --quick to scripts/test.sh (skips the sanitizer and fuzz stages)
#     --keep    leaves the root in place afterwards (default: removed)
#     --root    where to build it (default: a new directory under ${TMPDIR:-/tmp})
# Needs: root, mmdebstrap (apt-get install mmdebstrap), git, network access to a Debian mirror.
set -euo pipefail
cd "$(dirname "$0")/.."

quick="" keep=0 root=""
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick="--quick" ;;
    --keep) keep=1 ;;
    --root) root=${2:?--root needs a directory}; shift ;;
    *) echo "clean-root-check: unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
[ "$(id -u)" -eq 0 ] || { echo "clean-root-check: needs root (chroot and mounts)" >&2; exit 1; }
command -v mmdebstrap >/dev/null || { echo "clean-root-check: needs mmdebstrap (apt-get install mmdebstrap)" >&2; exit 1; }
git rev-parse --verify -q HEAD >/dev/null || { echo "clean-root-check: not a git checkout" >&2; exit 1; }
[ -n "$root" ] || root=$(mktemp -d "${TMPDIR:-/tmp}/lancer-clean-root.XXXXXX")
mirror=${LANCER_DEBIAN_MIRROR:-http://deb.debian.org/debian}

mounted=()
cleanup() {
  local status=$?
  # Unmount in reverse order; lazily, so a process still holding a file does not block the rest.
  for ((i = ${#mounted[@]} - 1; i >= 0; i--)); do umount -l "${mounted[i]}" 2>/dev/null || true; done
  if [ "$keep" -eq 0 ] && [ -d "$root" ]; then
    # Never delete through a mount that is still there.
    if grep -q " $root/" /proc/mounts; then
      echo "clean-root-check: $root still has mounts, left in place" >&2
    else
      rm -rf --one-file-system "$root"
    fi
  fi
  exit "$status"
}
trap cleanup EXIT INT TERM

start=$(date +%s)
echo "clean-root-check: building Debian 12 (bookworm) minbase in $root"
mmdebstrap --variant=minbase --quiet bookworm "$root" \
  "deb $mirror bookworm main" "deb $mirror bookworm-updates main" \
  "deb http://deb.debian.org/debian-security bookworm-security main"

echo "clean-root-check: copying $(git rev-parse --short HEAD) (git archive HEAD) to /root/lancer"
mkdir -p "$root/root/lancer"
git archive HEAD | tar -x -C "$root/root/lancer"
cp /etc/resolv.conf "$root/etc/resolv.conf"

for m in proc sys dev; do
  mount --rbind "/$m" "$root/$m"
  mount --make-rslave "$root/$m"
  mounted+=("$root/$m")
done

run() { chroot "$root" /usr/bin/env -i HOME=/root PATH=/usr/sbin:/usr/bin:/sbin:/bin TERM=dumb \
  /bin/bash -c "cd /root/lancer && $1"; }
echo "clean-root-check: scripts/setup.sh"
run "scripts/setup.sh"
echo "clean-root-check: scripts/test.sh $quick"
run "scripts/test.sh $quick"
echo "clean-root-check: PASS in $(( $(date +%s) - start )) s (the README's two commands on a fresh Debian 12 root)"
