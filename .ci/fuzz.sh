#!/usr/bin/env bash
# Fuzzes the readers of hostile input for a bounded total time: the scene loader
# (tests/fuzz/fuzz_scene.cpp) half of it, the image reader of `compare` (fuzz_image.cpp: PFM and
# PNG seeds) and the CSV reader of `plot` (fuzz_csv.cpp) a quarter each.
#
#   .ci/fuzz.sh [SECONDS]      default 120, the total
#
# Configures a clang build with LANCER_FUZZ=ON in build-fuzz/, builds only the fuzzers, and runs
# each with -max_len=4096 on its seed corpus (scenes/*.json and tests/fuzz/corpus/ for scenes,
# tests/fuzz/corpus-image/, tests/fuzz/corpus-csv/) plus the working corpus it keeps in
# build-fuzz/corpus-<name>/ between runs. Prints the number of executions. Exits non-zero on a
# finding (crash, sanitizer report, uncaught exception, non-finite pixel, bad error message,
# timeout, out of memory); the input is saved in build-fuzz/artifacts/. Turn each one into a case
# in tests/fuzz/test_regressions.cpp.
#
# Environment: BUILD_DIR (default build-fuzz). One fuzzing process at a time: the machine has 2
# cores.
set -euo pipefail

seconds="${1:-120}"
case "$seconds" in ''|*[!0-9]*) echo "usage: $0 [SECONDS]" >&2; exit 2 ;; esac

# cd prints the directory when CDPATH is set (and the path relative): keep it out of $root.
root="$(cd -- "$(dirname -- "$0")/.." >/dev/null && pwd)"
build="${BUILD_DIR:-$root/build-fuzz}"

cxx="${CXX:-}"
if [ -z "$cxx" ] || ! "$cxx" --version 2>/dev/null | grep -q clang; then
  cxx="$(command -v clang++ || command -v clang++-14 || true)"
fi
cc="$(command -v clang || command -v clang-14 || true)"
if [ -z "$cxx" ]; then echo "fuzz.sh: clang++ not found" >&2; exit 2; fi

mkdir -p "$build"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_COMPILER="$cxx" ${cc:+-DCMAKE_C_COMPILER="$cc"} \
  -DLANCER_FUZZ=ON -DLANCER_BUILD_BENCH=OFF >"$build/configure.log" 2>&1 \
  || { cat "$build/configure.log" >&2; exit 2; }
cmake --build "$build" --target fuzz_scene fuzz_image fuzz_csv -j2

mkdir -p "$build/artifacts"
status=0
total_runs=0
# fuzz NAME SECONDS SEEDS... [-- EXTRA FLAGS]: the first corpus folder receives new inputs; the
# seed folders are only read.
fuzz() {
  local name="$1" secs="$2"
  shift 2
  local seeds=() extra=()
  while [ $# -gt 0 ] && [ "$1" != "--" ]; do seeds+=("$1"); shift; done
  [ $# -gt 0 ] && shift
  extra=("$@")
  mkdir -p "$build/corpus-$name"
  local log="$build/fuzz-$name.log" st=0
  "$build/fuzz_$name" "$build/corpus-$name" "${seeds[@]}" "${extra[@]}" -max_len=4096 \
    -timeout=10 -rss_limit_mb=4096 -max_total_time="$secs" -print_final_stats=1 \
    -artifact_prefix="$build/artifacts/$name-" >"$log" 2>&1 || st=$?
  local runs
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | awk '{s += $1} END {print s + 0}')
  total_runs=$((total_runs + runs))
  echo "fuzz.sh: $name: $runs executions in $secs s, exit status $st"
  if [ "$st" -ne 0 ]; then
    tail -n 40 "$log"
    grep -h -E 'lancer fuzz finding|^SUMMARY|ERROR: (Address|Undefined|libFuzzer)|runtime error' \
      "$log" >&2 || true
    status=1
  fi
}
half=$((seconds / 2))
quarter=$((seconds / 4))
fuzz scene "$half" "$root/scenes" "$root/tests/fuzz/corpus" -- -dict="$root/tests/fuzz/scene.dict"
# OpenImageIO keeps caches for the life of the process: not leaks of lancer's.
fuzz image "$quarter" "$root/tests/fuzz/corpus-image" -- -detect_leaks=0
fuzz csv "$((seconds - half - quarter))" "$root/tests/fuzz/corpus-csv"
echo "fuzz.sh: $total_runs executions in ${seconds} s, exit status $status"
if [ "$status" -ne 0 ]; then
  echo "fuzz.sh: FINDING; input saved in $build/artifacts/:" >&2
  ls -1t "$build/artifacts" | head -n 5 >&2 || true
  exit 1
fi
