#!/usr/bin/env bash
# Installs the Debian 12 packages lancer builds with, when any is missing. Safe to run again.
set -euo pipefail

packages=(
  cmake g++ make pkg-config
  libxsimd-dev            # SIMD batches (xsimd 8)
  libpng-dev libjpeg-dev libtiff-dev libopenexr-dev  # PNG, JPEG, TIFF, OpenEXR images
  libopenimageio-dev      # the other image formats (BMP, Targa, HDR), in the image module
  openimageio-tools       # OpenImageIO's CMake package names /usr/bin/iconvert, which only this ships
  nlohmann-json3-dev      # scene files
  libcli11-dev            # command line
  libtbb-dev              # threads
  libembree-dev           # the peer engine lancer measures against
  libgtest-dev libgmock-dev googletest
  libbenchmark-dev
  libcairo2-dev           # figures: PNG, SVG and PDF from one drawing
  clang libclang-rt-14-dev  # libFuzzer and the sanitizer runtimes
  libopenmpi-dev openmpi-bin  # mpirun -np N lancer render (docs/mpi.md; optional at build time)
  qemu-user               # runs the binary as CPUs without AVX / AVX-512 (.ci/qemu.sh)
  glmark2-data            # the Stanford bunny (scenes/prims/bunny.json, test Prims.WatertightStanfordBunny)
  ccache                  # setup.sh and test.sh compile through it when present
  jq python3              # scripts/measure.sh and scaling.sh read bench's JSON; CI's skip check
  libbenchmark-tools python3-scipy  # Google Benchmark's compare.py (README), which imports scipy
  strace                  # the fsync-order test of atomic replace (tests/fuzz/test_edges.cpp)
  pybind11-dev python3-dev python3-numpy  # the Python module (docs/python.md)
  python3-pytest          # its tests (tests/python/)
  jupyter-nbconvert python3-ipykernel python3-matplotlib  # the example notebook, run headless in CI
  libsimde-dev            # x86 intrinsics over NEON: the kernels' aarch64 build (docs/platforms.md)
)
# On x86-64, the aarch64 cross build that .ci/arm.sh runs under qemu-aarch64: Debian's cross
# compiler and the arm64 packages the engine, the CLI and the core tests link (multiarch). The
# image modules, cairo, Embree and MPI are left out of that build, so none of theirs.
foreign=()
if [ "$(dpkg --print-architecture)" = amd64 ]; then
  packages+=(g++-aarch64-linux-gnu)
  foreign=(libtbb-dev libgtest-dev libgmock-dev libpng-dev libjpeg-dev)
  for p in "${foreign[@]}"; do packages+=("$p:arm64"); done
fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "deps: installing ${missing[*]}"
sudo=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "deps: need root or sudo to apt-get install ${missing[*]}" >&2; exit 1; }
  sudo="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
if [ ${#foreign[@]} -gt 0 ] && ! dpkg --print-foreign-architectures | grep -qx arm64; then
  $sudo dpkg --add-architecture arm64
fi
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
