#!/usr/bin/env bash
# Fuzzes the scene loader (tests/fuzz/fuzz_scene.cpp) for a bounded time.
#
#   .ci/fuzz.sh [SECONDS]      default 120
#
# Configures a clang build with LANCER_FUZZ=ON in build-fuzz/, builds only the fuzzer, and runs
# it with -max_len=4096 on the seed corpus (scenes/*.json, tests/fuzz/corpus/) plus the working
# corpus it keeps in build-fuzz/corpus/ between runs. Prints the number of executions. Exits
# non-zero on a finding (crash, sanitizer report, uncaught exception, non-finite pixel, bad error
# message, timeout, out of memory); the input is saved in build-fuzz/artifacts/. Turn each one
# into a case in tests/fuzz/test_regressions.cpp.
#
# Environment: BUILD_DIR (default build-fuzz). One fuzzing process: the machine has 2 cores.
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
cmake --build "$build" --target fuzz_scene -j2

mkdir -p "$build/corpus" "$build/artifacts"
log="$build/fuzz.log"
status=0
# The first corpus folder receives new inputs; the seed folders are only read.
"$build/fuzz_scene" "$build/corpus" "$root/scenes" "$root/tests/fuzz/corpus" \
  -dict="$root/tests/fuzz/scene.dict" -max_len=4096 -timeout=10 -rss_limit_mb=4096 \
  -max_total_time="$seconds" -print_final_stats=1 -artifact_prefix="$build/artifacts/" \
  >"$log" 2>&1 || status=$?

runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | awk '{s += $1} END {print s + 0}')
if [ "$status" -ne 0 ]; then
  tail -n 40 "$log"
else
  grep -E '^#[0-9]+ *DONE|^Done|^lancer fuzz:' "$log" || true
fi
echo "fuzz.sh: $runs executions in ${seconds} s, exit status $status"
if [ "$status" -ne 0 ]; then
  grep -h -E 'lancer fuzz finding|^SUMMARY|ERROR: (Address|Undefined|libFuzzer)|runtime error' \
    "$log" >&2 || true
  echo "fuzz.sh: FINDING; input saved in $build/artifacts/:" >&2
  ls -1t "$build/artifacts" | head -n 5 >&2 || true
  exit 1
fi
