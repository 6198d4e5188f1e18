#!/usr/bin/env bash
# ASan + UBSan build of the test suite (tests/fuzz/README.md, "Sanitizer build"): configures
# build-asan with the project's default compiler, builds the GoogleTest suite, the CLI and the
# fuzz corpus replays, and runs them all through CTest.
#
#   scripts/sanitize.sh [extra ctest arguments, e.g. -R fuzz_replay]
#
# Environment: BUILD_DIR (default build-asan), JOBS (default nproc), BUILD_TYPE (default
# Debug, so AI_DCHECKs are on) and OPT (default -O1: the usual ASan level, and the Highway
# kernels compile several times faster than at -O2/-O3).
# OpenImageIO, OpenEXR and oneTBB are not instrumented; scripts/sanitizers/*.supp holds the
# few suppressions they need, each with its reason.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
build=${BUILD_DIR:-build-asan}
jobs=${JOBS:-$(nproc)}
flags="${OPT:--O1} -g -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"

launcher=()
if command -v ccache > /dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
cmake -S . -B "$build" -G Ninja "${launcher[@]}" \
  -DCMAKE_BUILD_TYPE="${BUILD_TYPE:-Debug}" \
  -DCMAKE_CXX_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DAFTERIMAGE_BUILD_BENCH=OFF
cmake --build "$build" -j "$jobs"

# Every report is fatal (halt_on_error / -fno-sanitize-recover) and printed with a stack.
export ASAN_OPTIONS="halt_on_error=1:abort_on_error=1:detect_stack_use_after_return=1:strict_string_checks=1:check_initialization_order=1:detect_leaks=1${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$root/scripts/sanitizers/ubsan.supp${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
export LSAN_OPTIONS="suppressions=$root/scripts/sanitizers/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
ctest --test-dir "$build" --output-on-failure -j "$jobs" "$@"
