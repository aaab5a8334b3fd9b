#!/usr/bin/env bash
# The installed package as a user outside the tree gets it: installs the build to a temporary
# prefix, checks that lancer::lancer's link interface names only what a consumer needs (no
# OpenImageIO, Embree, Google Benchmark, xsimd), configures examples/trace_packets against the
# prefix with find_package(lancer), builds it and runs it on a scene: its packets of world-space
# rays must hit what lancer's primary mode hits and its rows must equal `lancer render`'s PFM.
# The installed CLI must write BMP and OpenEXR with the installed modules.
#   .ci/consumer.sh [BUILD_DIR] [SCENE]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
scene=${2:-scenes/lorenzi-reflections.json}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

cmake --install "$build" --prefix "$tmp/prefix" >/dev/null
targets=$(find "$tmp/prefix" -name 'lancerTargets.cmake')
[ -n "$targets" ] || { echo "consumer: no lancerTargets.cmake installed"; exit 1; }
link=$(grep -A1 'INTERFACE_LINK_LIBRARIES' "$targets" | tr -d '\n')
for bad in OpenImageIO embree benchmark xsimd nlohmann lancer_tools lancer_warnings lancer_fp; do
  if grep -qi "$bad" <<<"$link"; then echo "consumer: lancer::lancer links $bad: $link"; exit 1; fi
done
if grep -rqE '#include.*(xsimd|immintrin|tbb|nlohmann|OpenImageIO)' "$tmp/prefix/include"; then echo "consumer: an installed header includes a SIMD or tool header"; exit 1; fi

cmake -S examples/trace_packets -B "$tmp/example" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$tmp/prefix" >/dev/null
cmake --build "$tmp/example" -j"$(nproc)" >/dev/null
"$build/lancer" render "$scene" -o "$tmp/render.pfm" >/dev/null
"$tmp/example/trace_packets" "$scene" "$tmp/render.pfm"
# The installed CLI writes BMP through the installed image module and OpenEXR through the
# installed float module (each found from the executable), not the build tree's.
for out in render.bmp:lancer-oiio.so render.exr:lancer-float.so; do
  file=${out%%:*} module=${out#*:}
  LD_DEBUG=files "$tmp/prefix/bin/lancer" render "$scene" -o "$tmp/$file" >/dev/null 2>"$tmp/ld"
  grep -q "file=$tmp/prefix/lib[^ ]*/lancer/$module" "$tmp/ld" ||
    { echo "consumer: the installed lancer did not load the installed $module"; exit 1; }
  [ -s "$tmp/$file" ] || { echo "consumer: the installed lancer wrote no $file"; exit 1; }
done
echo "consumer: find_package(lancer) from an install prefix, built and identical"
