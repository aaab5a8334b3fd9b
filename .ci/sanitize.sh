#!/usr/bin/env bash
# Builds the `asan` preset (build-asan/: Debug, AddressSanitizer + UndefinedBehaviorSanitizer,
# -fno-sanitize-recover=all, no benchmarks) and runs the whole CTest suite under it. Any
# sanitizer report, leak or failing test makes it exit non-zero.
#
#   .ci/sanitize.sh [extra ctest arguments, e.g. -R lancer_hostile]
#
# Tests run as many at a time as the machine has cores (CTEST_PARALLEL_LEVEL overrides): one at
# a time, this suite was half of CI's time. The tests that bound how long a refused command may
# take are RUN_SERIAL (tests/fuzz/CMakeLists.txt), alone even here.
set -euo pipefail
cd "$(dirname "$0")/.."

export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:check_initialization_order=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
# fontconfig (through cairo's text) keeps a cache it never frees: suppressed, and nothing else.
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$PWD/.ci/lsan.supp:print_suppressions=0}"

cmake --preset asan
cmake --build --preset asan -j2
ctest --preset asan -j"${CTEST_PARALLEL_LEVEL:-$(nproc)}" "$@"
