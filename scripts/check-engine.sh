#!/usr/bin/env bash
# The engine includes nothing from the tools (docs/architecture.md): no file of src/engine/,
# src/isa/'s kernel units or the engine's headers names a tool header. Exit 1 naming each
# include that does.
set -euo pipefail
cd "$(dirname "$0")/.."
tools='bench|compare|flux|generate|image_module|mpi|peak|peer|plot|profile|progress|trade'
engine_headers=$(ls include/lancer/*.hpp | grep -Ev "/($tools)\.hpp$")
files=(src/engine/* src/isa/sse42.cpp src/isa/avx2.cpp src/isa/avx512.cpp include/lancer/packet/*.hpp
       include/lancer/packet/prim/*.hpp $engine_headers)
bad=$(grep -nE "#include \"lancer/($tools)\.hpp\"" "${files[@]}" || true)
if [ -n "$bad" ]; then
  echo "check-engine: the engine includes tool headers:"
  echo "$bad"
  exit 1
fi
echo "check-engine: ${#files[@]} engine files include no tool header"
