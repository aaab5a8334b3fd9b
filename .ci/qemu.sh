#!/usr/bin/env bash
# The same binary on CPUs other than this one, emulated by qemu-user: an SSE4.2-only CPU
# (Nehalem: no AVX at all) and an AVX2-only one (Haswell: no AVX-512). On each, for every scene in
# scenes/: `lancer validate` (packets == reference, bit for bit, at every width that CPU runs) and
# a render at that CPU's widest width compared byte for byte with this machine's render at the
# same width; then the reference suite and the packet suite's random-scene cases under the same
# CPU model. Any illegal instruction, difference or failure exits non-zero.
#
#   .ci/qemu.sh [build dir, default build]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
lancer="$build/lancer"
[ -x "$lancer" ] || { echo "qemu: $lancer not built" >&2; exit 1; }
command -v qemu-x86_64 >/dev/null || { echo "qemu: qemu-x86_64 missing (apt-get install qemu-user)" >&2; exit 1; }

out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# qemu's TCG warns about CPUID bits it cannot emulate; those lines are noise.
emulate() { local cpu=$1; shift; qemu-x86_64 -cpu "$cpu" "$@" 2> >(grep -v "TCG doesn't support" >&2); }

status=0
for spec in Nehalem:4 Haswell:8; do
  cpu=${spec%%:*} width=${spec##*:}
  for scene in scenes/*.json; do
    name=$(basename "$scene" .json)
    if ! emulate "$cpu" "$lancer" validate "$scene" >"$out/v.txt"; then
      echo "qemu $cpu: validate $scene failed"; cat "$out/v.txt"; status=1; continue
    fi
    grep -q "^ *$width " "$out/v.txt" || { echo "qemu $cpu: validate did not run width $width"; cat "$out/v.txt"; status=1; }
    # Small renders: emulation is slow. PFM keeps the float bits.
    args=(--resolution 96x64 --precision exact --threads 1 --width "$width")
    emulate "$cpu" "$lancer" render "$scene" -o "$out/$name-emu.pfm" "${args[@]}" >/dev/null
    "$lancer" render "$scene" -o "$out/$name-native.pfm" "${args[@]}" >/dev/null
    if ! cmp -s "$out/$name-emu.pfm" "$out/$name-native.pfm"; then
      echo "qemu $cpu: $scene at width $width differs from this machine's render"; status=1
    fi
  done
  # The widest widths this CPU must not offer.
  if emulate "$cpu" "$lancer" render scenes/lorenzi-diffuse.json -o "$out/x.pfm" --width $((width * 2)) \
      >/dev/null 2>&1; then
    echo "qemu $cpu: width $((width * 2)) ran on a CPU without it"; status=1
  fi
  # The reference suite, and the packet suite's cases that compare every width this CPU runs
  # with the reference on seeded random scenes, odd sizes, inactive lanes and dispatch (the
  # shipped scenes are validate's above; the whole packet suite takes tens of minutes emulated).
  packet_cases='PacketIdentity.RandomScenes:PacketIdentity.SupersampledAndOddSizes:PacketKernel.*'
  packet_cases+=':PacketPrimary.SameDistancesAsTheReference:PacketDispatch.*'
  for t in "test_reference" "test_packet --gtest_filter=$packet_cases"; do
    exe=${t%% *} args=${t#"$exe"}
    [ -x "$build/tests/$exe" ] || continue
    # shellcheck disable=SC2086 # args is one option or none
    emulate "$cpu" "$build/tests/$exe" --gtest_brief=1 $args >"$out/t.txt" 2>&1 ||
      { echo "qemu $cpu: $exe failed"; cat "$out/t.txt"; status=1; }
  done
  [ $status -eq 0 ] && echo "qemu $cpu: validate, width-$width renders and the packet/reference suites pass"
done
# qemu 7.2 decodes a gather whose VSIB index is xmm4/ymm4 as having no index (SIB's 100b means
# none for general registers only), so such a gather reads element 0 in every lane under emulation
# and the renders above differ or not with GCC's register choice. The kernels keep gather indexes
# out of ymm4 (packet/kernel.hpp gather8); any gather that does not is a failure here, whatever
# the renders said.
if objdump -d --no-show-raw-insn "$lancer" | grep -E 'gather[a-z]*[[:space:]].*,%[xy]mm4,' >"$out/g.txt"; then
  echo "qemu: gathers indexed by xmm4/ymm4, which qemu 7.2 emulates wrongly:"; head -5 "$out/g.txt"; status=1
fi
exit $status
