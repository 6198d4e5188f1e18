#!/usr/bin/env bash
# Installs dependencies, builds (Release), runs the whole test suite through CTest, compares
# every method's outputs with the golden baseline of this lane width (scripts/golden.sh) and
# checks the installed library and its examples (scripts/check-package.sh).
# --portable: the portable configuration instead (-DAFTERIMAGE_NATIVE=OFF: x86-64-v3, AVX2 and
# FMA, 8 float lanes) in build-portable/, for a host whose native build is wider (AVX-512),
# with libafterimage static, so that both kinds of package are checked (and without the kernel
# micro-benchmarks, which CI does not run).
set -euo pipefail
cd "$(dirname "$0")/.."
build=build
config=()
package=(--vendored)
if [[ "${1:-}" == "--portable" ]]; then
  build=build-portable
  config=(-DAFTERIMAGE_NATIVE=OFF -DBUILD_SHARED_LIBS=OFF -DAFTERIMAGE_BUILD_BENCH=OFF)
  package=()
elif [[ $# -gt 0 ]]; then
  echo "usage: bash scripts/test.sh [--portable]" >&2
  exit 2
fi
# Each step's wall time, on stderr, so that a slow step shows in CI's log.
step() {
  local start=$SECONDS
  "$@"
  echo "test.sh: $(($SECONDS - start)) s: $*" >&2
}
step bash scripts/setup-deps.sh
step cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release "${config[@]}"
step cmake --build "$build" -j "$(nproc)"
step ctest --test-dir "$build" --output-on-failure -j "$(nproc)"
step bash scripts/golden.sh check --bin "$build/afterimage"
step bash scripts/check-package.sh "$build" "${package[@]}"
echo "test.sh: $SECONDS s in all" >&2
