#!/usr/bin/env bash
# The installed package as a user outside the tree gets it: installs the build to a temporary
# prefix, checks that lancer::lancer's link interface names only what a consumer needs (no
# OpenImageIO, Embree, Google Benchmark, xsimd), configures examples/trace_packets against the
# prefix with find_package(lancer), builds it and runs it on a scene: its packets of world-space
# rays must hit what lancer's primary mode hits and its rows must equal `lancer render`'s PFM.
# The installed CLI must write BMP and OpenEXR with the installed modules. Given a shared build
# (-DBUILD_SHARED_LIBS=ON), also checks that liblancer.so exports the API and nothing else.
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

# A shared build (-DBUILD_SHARED_LIBS=ON) exports the API alone: every defined dynamic symbol is
# lancer::api's, the few free functions and InputError the installed headers mark LANCER_API,
# the C API, or a weak instantiation of the C++ library's own templates (std::, __gnu_cxx::).
so=$(find "$tmp/prefix" -name 'liblancer.so*' -type f | head -1)
if [ -n "$so" ]; then
  api='lancer::api::|lancer::InputError|lancer::to_string\(lancer::Precision\)|lancer::parse_precision'
  api+='|lancer::load_scene|lancer::parse_scene|lancer::read_scene_file|lancer_[a-z_]+$'
  api+='|(typeinfo|typeinfo name|vtable) for lancer::InputError'
  others=$(nm -D --defined-only -C "$so" | sed -E 's/^[0-9a-f]+ [A-Za-z] //; s/^void //' |
           grep -vE "^($api)" | grep -vE '^(std::|__gnu_cxx::|(typeinfo|typeinfo name|vtable|VTT|guard variable) for (std::|__gnu_cxx::)|_init$|_fini$)' || true)
  if [ -n "$others" ]; then
    echo "consumer: $(basename "$so") exports more than the API:"; head -5 <<<"$others"; exit 1
  fi
  nm -D --defined-only "$so" | grep -q ' T lancer_intersect$' ||
    { echo "consumer: $(basename "$so") lacks the C API"; exit 1; }
fi

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
