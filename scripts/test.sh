#!/usr/bin/env bash
# The second command: every test. Installs what is missing and builds first, so it works on a
# fresh clone. Stages: the Release suite (ctest), validate on every scene, the binary under
# emulated SSE4.2-only and AVX2-only CPUs, renders across MPI ranks, then, unless --quick, the same suite under
# ASan+UBSan and a bounded fuzzing run of the scene loader.
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
[ "${1:-}" = "--quick" ] && quick=1

scripts/deps.sh
# The source's own rules (docs/architecture.md): the engine includes no tool header; no source
# file over 700 lines, no function outside the tests over 120.
scripts/check-engine.sh
python3 scripts/check-sizes.py
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)"
(cd build && ctest --output-on-failure -j"$(nproc)" --timeout 1200)

for s in scenes/*.json; do build/lancer validate "$s" >/dev/null || { echo "validate: $s differs"; exit 1; }; done
echo "validate: every scene in scenes/ bit-identical at every width this CPU runs"

# The same binary on an SSE4.2-only and an AVX2-only CPU (qemu-user).
.ci/qemu.sh build

# The installed package, used from outside the tree (find_package(lancer); about 10 s).
.ci/consumer.sh build

# mpirun -np 2 and 4 byte-identical to one process; failures end every rank (skipped without MPI).
.ci/mpi.sh build

if [ "$quick" -eq 0 ]; then
  [ -x .ci/sanitize.sh ] && .ci/sanitize.sh
  [ -x .ci/fuzz.sh ] && .ci/fuzz.sh "${LANCER_FUZZ_SECONDS:-120}"
fi
