#!/usr/bin/env bash
# aarch64 under emulation: cross-builds the engine, the CLI and the core test suites for aarch64
# (Debian's g++-aarch64-linux-gnu against the arm64 packages; cmake/aarch64-linux-gnu.cmake) into
# build-arm, then runs them under qemu-aarch64 (qemu-user):
#   - `lancer validate` on every scene in scenes/ and scenes/prims/ (those at 160x100), exact and
#     double (packets == reference, bit for bit, at every width NEON runs: float 4, double 2);
#   - the reference suite and the packet suite's core cases;
#   - renders of every scene in scenes/ and scenes/prims/, exact and double, at every width
#     aarch64 runs, compared byte for byte with the x86-64 build's at every width this machine
#     runs.
# Any difference or failure exits non-zero. Prints the stage's minutes.
#
#   .ci/arm.sh [x86-64 build dir, default build] [aarch64 build dir, default build-arm]
set -euo pipefail
cd "$(dirname "$0")/.."
x86=${1:-build}
arm=${2:-build-arm}
start=$(date +%s)
[ -x "$x86/lancer" ] || { echo "arm: $x86/lancer not built" >&2; exit 1; }
command -v aarch64-linux-gnu-g++ >/dev/null ||
  { echo "arm: aarch64-linux-gnu-g++ missing (scripts/deps.sh installs it)" >&2; exit 1; }
command -v qemu-aarch64 >/dev/null || { echo "arm: qemu-aarch64 missing (apt-get install qemu-user)" >&2; exit 1; }

launcher=""
command -v ccache >/dev/null && launcher=ccache
# Without the image modules, cairo, Embree, MPI and Python (no arm64 packages of theirs are
# installed): PFM, PPM, PNG and JPEG are written directly; figures and the Embree peer are refused.
cmake --no-warn-unused-cli -S . -B "$arm" --toolchain cmake/aarch64-linux-gnu.cmake -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_CXX_COMPILER_LAUNCHER="$launcher" -DLANCER_WITH_IMAGE_MODULES=OFF \
  -DLANCER_WITH_PLOTS=OFF -DLANCER_WITH_EMBREE=OFF -DLANCER_MPI=OFF -DLANCER_BUILD_BENCH=OFF \
  -DLANCER_PYTHON=OFF \
  -DCMAKE_GTEST_DISCOVER_TESTS_DISCOVERY_MODE=PRE_TEST >/dev/null
cmake --build "$arm" -j"$(nproc)" --target lancer_cli test_reference test_packet
readelf -h "$arm/lancer" | grep -q AArch64 || { echo "arm: $arm/lancer is not an aarch64 binary" >&2; exit 1; }
built=$(date +%s)

out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# No -L /usr/aarch64-linux-gnu: the loader must come from the same glibc build as the libc it
# maps, and the arm64 libc6 that multiarch installs (with /lib/ld-linux-aarch64.so.1) is not the
# cross toolchain's copy; mixing the two hangs the first pthread_create.
emulate() { qemu-aarch64 "$@"; }
# The packet widths a validate report lists (its table's first column).
widths_of() { grep -oE '^ +[0-9]+ ' | tr -d ' ' | tr '\n' ' '; }

status=0
# What the cross build leaves out is refused as bad input (exit 2, one line, no file), before any
# work: a TIFF (the image modules) and a figure (cairo).
refused() {
  local what=$1 file=$2 rc=0
  shift 2
  emulate "$arm/lancer" "$@" >/dev/null 2>"$out/err.txt" || rc=$?
  if [ $rc -ne 2 ] || [ -e "$file" ] || [ "$(wc -l <"$out/err.txt")" -ne 1 ]; then
    echo "arm: $what gave exit $rc (2 expected, one line, no file)"; cat "$out/err.txt"; status=1
  fi
}
refused "a TIFF without the image modules" "$out/x.tif" \
  render scenes/lorenzi-diffuse.json -o "$out/x.tif" --resolution 16x16 --threads 1
printf 'a,b\n1,2\n3,4\n' >"$out/d.csv"
refused "a figure without cairo" "$out/p.svg" plot "$out/d.csv" --x a --y b -o "$out/p.svg"

scenes=(scenes/*.json scenes/prims/*.json)
compared=0
for scene in "${scenes[@]}"; do
  # The meshes' scenes at a smaller size: bunny-studio alone takes 18 s natively, minutes emulated.
  size=()
  [[ "$scene" == scenes/prims/* ]] && size=(--resolution 160x100)
  for precision in exact double; do
    if ! emulate "$arm/lancer" validate "$scene" --precision "$precision" "${size[@]}" >"$out/v.txt"; then
      echo "arm: validate $scene --precision $precision failed"; cat "$out/v.txt"; status=1
    fi
    neon=4
    [ "$precision" = double ] && neon=2
    grep -qE "^ +$neon +neon64 " "$out/v.txt" ||
      { echo "arm: validate $scene did not run NEON's width $neon"; cat "$out/v.txt"; status=1; }
    # Small renders: emulation is slow. PFM keeps the float bits. Every width each side runs
    # (aarch64's from its validate above) against x86-64's width 1, the reference.
    args=(--resolution 96x64 --precision "$precision" --threads 2)
    "$x86/lancer" render "$scene" -o "$out/ref.pfm" "${args[@]}" --width 1 >/dev/null
    x86_widths=$("$x86/lancer" validate "$scene" --precision "$precision" --resolution 8x8 | widths_of)
    arm_widths="1 $(widths_of <"$out/v.txt")"
    for side in x86 arm; do
      if [ "$side" = x86 ]; then run=("$x86/lancer") widths=$x86_widths; else
        run=(emulate "$arm/lancer") widths=$arm_widths
      fi
      for width in $widths; do
        "${run[@]}" render "$scene" -o "$out/$side.pfm" "${args[@]}" --width "$width" >/dev/null
        compared=$((compared + 1))
        if ! cmp -s "$out/$side.pfm" "$out/ref.pfm"; then
          echo "arm: $scene $precision width $width on $side differs from x86-64's width 1"; status=1
        fi
      done
    done
  done
done
echo "arm: $compared renders of ${#scenes[@]} scenes (exact and double) compared with x86-64's"

# The reference suite and the packet suite's cases that compare every width with the reference
# on seeded random scenes, odd sizes, inactive lanes and dispatch.
packet_cases='PacketIdentity.RandomScenes:PacketIdentity.SupersampledAndOddSizes:PacketKernel.*'
packet_cases+=':PacketPrimary.SameDistancesAsTheReference:PacketDispatch.*'
for t in "test_reference" "test_packet --gtest_filter=$packet_cases"; do
  exe=${t%% *} args=${t#"$exe"}
  # shellcheck disable=SC2086 # args is one option or none
  emulate "$arm/tests/$exe" --gtest_brief=1 $args >"$out/t.txt" 2>&1 ||
    { echo "arm: $exe failed"; cat "$out/t.txt"; status=1; }
done

end=$(date +%s)
[ $status -eq 0 ] && echo "arm: validate, the core suites and byte-identical renders pass under qemu-aarch64"
echo "arm: stage took $(awk -v s=$((end - start)) 'BEGIN { printf "%.1f", s / 60 }') min" \
  "(build $((built - start)) s, emulated runs $((end - built)) s)"
exit $status
