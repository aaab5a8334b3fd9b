#!/usr/bin/env bash
# Guest instructions per ray of a render, counted by qemu-user, the same way on x86-64 and on
# aarch64: each guest instruction its own translation block (-singlestep) and every block's
# execution logged (-d exec,nochain), the log's lines counted. Two renders of one scene at two
# sizes; the difference of their counts over the difference of their rays, so that start-up,
# loading, preparing and writing cancel. A count, not a speed: no claim about either machine's
# time follows from it (docs/platforms.md).
#
#   scripts/icount.sh x86 [BUILD] SCENE [render options...]   # qemu-x86_64 -cpu Nehalem (SSE4.2)
#   scripts/icount.sh arm [BUILD] SCENE [render options...]   # qemu-aarch64 (NEON)
#
# BUILD defaults to build (x86) or build-arm (arm). One thread; sizes 32x32 and 64x64 unless
# LANCER_ICOUNT_SIZES="A B" says otherwise. Prints "instructions/ray rays instructions".
set -euo pipefail
cd "$(dirname "$0")/.."
arch=${1:?usage: scripts/icount.sh x86|arm [BUILD] SCENE [render options...]}
shift
case "$arch" in
  x86) build=build emu=(qemu-x86_64 -cpu Nehalem) ;;
  arm) build=build-arm emu=(qemu-aarch64) ;;
  *) echo "icount: the first argument is x86 or arm, not '$arch'" >&2; exit 2 ;;
esac
if [ -d "${1:-}" ]; then build=$1; shift; fi
scene=${1:?usage: scripts/icount.sh x86|arm [BUILD] SCENE [render options...]}
shift
[ -x "$build/lancer" ] || { echo "icount: $build/lancer not built" >&2; exit 2; }
read -r small large <<<"${LANCER_ICOUNT_SIZES:-32x32 64x64}"

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Prints "instructions rays" of one render at size $1.
count() {
  mkfifo "$tmp/log"
  wc -l <"$tmp/log" >"$tmp/n" &
  "${emu[@]}" -singlestep -d exec,nochain -D "$tmp/log" "$build/lancer" render "$scene" \
    -o "$tmp/out.pfm" --resolution "$1" --threads 1 "${@:2}" >"$tmp/report"
  wait
  rm "$tmp/log"
  echo "$(cat "$tmp/n") $(grep -oE '[0-9]+ in all' "$tmp/report" | cut -d' ' -f1)"
}
read -r n0 r0 < <(count "$small" "$@")
read -r n1 r1 < <(count "$large" "$@")
[ "$r1" -gt "$r0" ] || { echo "icount: the larger render traced no more rays" >&2; exit 1; }
awk -v n0="$n0" -v n1="$n1" -v r0="$r0" -v r1="$r1" \
  'BEGIN { printf "%.1f %d %d\n", (n1 - n0) / (r1 - r0), r1 - r0, n1 - n0 }'
