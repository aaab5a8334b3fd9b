# Cross-compiling lancer for aarch64 on a Debian x86-64 machine: Debian's cross compiler
# (g++-aarch64-linux-gnu) against the arm64 packages installed beside the native ones (multiarch:
# dpkg --add-architecture arm64; scripts/deps.sh installs both). The binaries run under
# qemu-aarch64 (qemu-user), which is also CMake's emulator for them. See docs/platforms.md.
#
#   cmake -S . -B build-arm --toolchain cmake/aarch64-linux-gnu.cmake
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
# Multiarch: arm64 libraries and their CMake packages live in /usr/lib/aarch64-linux-gnu.
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
# Header-only packages of architecture "all" put their CMake files in the build machine's
# multiarch directory (xsimd: /usr/lib/x86_64-linux-gnu/cmake/xsimd); the headers are the same.
if(NOT xsimd_DIR)
  file(GLOB _lancer_xsimd_dirs /usr/lib/*-linux-gnu*/cmake/xsimd)
  list(GET _lancer_xsimd_dirs 0 _lancer_xsimd_dir)
  set(xsimd_DIR "${_lancer_xsimd_dir}" CACHE PATH "xsimd's CMake package")
endif()
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64)
