#!/usr/bin/env bash
# Runs one libFuzzer harness with the project's settings (tests/fuzz/README.md):
#
#   tests/fuzz/run_fuzzer.sh HARNESS [libFuzzer flags...]
#   e.g. tests/fuzz/run_fuzzer.sh fuzz_state_loader -runs=1000000
#
# New inputs go to $WORK/<harness> (default build-fuzz/work), seeded from the committed
# corpus, which is only read; crashes land in $WORK/artifacts/<harness>/. In-process, one core.
# Merge new coverage back with:
#   build-fuzz/tests/fuzz/HARNESS -merge=1 tests/fuzz/corpus/HARNESS $WORK/HARNESS
# Environment: FUZZ_BUILD (default build-fuzz), WORK (default $FUZZ_BUILD/work).
set -euo pipefail
cd "$(dirname "$0")/../.."
h=${1:?usage: $0 HARNESS [libFuzzer flags...]}
shift
build=${FUZZ_BUILD:-build-fuzz}
work=${WORK:-$build/work}
bin=$build/tests/fuzz/$h
[ -x "$bin" ] || { echo "$bin: not built (see tests/fuzz/README.md)" >&2; exit 2; }
mkdir -p "$work/$h" "$work/artifacts/$h"
# Scratch files of the harnesses go to memory, not disk.
if [ -d /dev/shm ] && [ -w /dev/shm ]; then export TMPDIR=/dev/shm; fi
# Leaks are reported (uninstrumented libraries' one-time allocations are suppressed, with
# reasons, in scripts/sanitizers/lsan.supp); UBSan stops at the first report.
export LSAN_OPTIONS="suppressions=$(pwd)/scripts/sanitizers/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$(pwd)/scripts/sanitizers/ubsan.supp${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
exec "$bin" -rss_limit_mb=2048 -malloc_limit_mb=1024 -timeout=10 \
  -dict=tests/fuzz/dict/$h.dict -artifact_prefix="$work/artifacts/$h/" -print_final_stats=1 \
  "$@" "$work/$h" tests/fuzz/corpus/"$h"
