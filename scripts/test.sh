#!/usr/bin/env bash
# Installs dependencies, builds (Release) and runs the whole test suite through CTest.
# --portable: the portable configuration instead (-DAFTERIMAGE_NATIVE=OFF: x86-64-v3, AVX2 and
# FMA, 8 float lanes) in build-portable/, for a host whose native build is wider (AVX-512).
set -euo pipefail
cd "$(dirname "$0")/.."
build=build
config=()
if [[ "${1:-}" == "--portable" ]]; then
  build=build-portable
  config=(-DAFTERIMAGE_NATIVE=OFF)
elif [[ $# -gt 0 ]]; then
  echo "usage: bash scripts/test.sh [--portable]" >&2
  exit 2
fi
bash scripts/setup-deps.sh
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release "${config[@]}"
cmake --build "$build" -j "$(nproc)"
ctest --test-dir "$build" --output-on-failure -j "$(nproc)"
