#!/usr/bin/env bash
# The second command: every test. Installs what is missing and builds first, so it works on a
# fresh clone. Stages: the Release suite (ctest; a skip not listed in .ci/expected-skips.txt
# fails), validate on every scene, the binary under emulated SSE4.2-only and AVX2-only CPUs,
# the aarch64 build under qemu-aarch64 (those two on x86-64 only), the Python module's tests and
# notebook, renders across MPI ranks, the README's commands, then, unless --quick, the same suite
# under ASan+UBSan and a bounded fuzzing run of the scene loader.
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
[ "${1:-}" = "--quick" ] && quick=1

scripts/deps.sh
# The source's own rules (docs/architecture.md): the engine includes no tool header; no source
# file over 700 lines, no function outside the tests over 120.
scripts/check-engine.sh
python3 scripts/check-sizes.py
launcher=""
command -v ccache >/dev/null && launcher=ccache
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER_LAUNCHER="$launcher"
cmake --build build -j"$(nproc)"
(cd build && ctest --output-on-failure -j"$(nproc)" --timeout 1200 --output-junit ctest-junit.xml)
# A skipped gtest case passes in ctest's summary: fail on any not listed as expected.
.ci/skips.py build/ctest-junit.xml

for s in scenes/*.json scenes/prims/*.json; do
  for p in exact double; do
    build/lancer validate --precision "$p" "$s" >/dev/null || { echo "validate: $s differs ($p)"; exit 1; }
  done
done
echo "validate: every scene in scenes/ and scenes/prims/ bit-identical at every width this CPU runs (exact and double)"

if [ "$(uname -m)" = x86_64 ]; then
  # The same binary on an SSE4.2-only and an AVX2-only CPU (qemu-user).
  .ci/qemu.sh build
  # The aarch64 build under qemu-aarch64: validate, the core suites, renders byte for byte
  # against this machine's (docs/platforms.md).
  .ci/arm.sh build build-arm
fi

# The Python module's tests (pytest) and the example notebook, executed headless.
.ci/python.sh build

# The installed package, used from outside the tree (find_package(lancer); about 10 s).
.ci/consumer.sh build

# mpirun -np 2 and 4 byte-identical to one process; failures end every rank (skipped without MPI).
.ci/mpi.sh build

# Every command of README.md's sh blocks, in order, in a scratch copy (about 3 minutes).
.ci/readme.sh build

if [ "$quick" -eq 0 ]; then
  [ -x .ci/sanitize.sh ] && .ci/sanitize.sh
  [ -x .ci/fuzz.sh ] && .ci/fuzz.sh "${LANCER_FUZZ_SECONDS:-120}"
fi
