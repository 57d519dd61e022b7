#!/usr/bin/env bash
# Builds the tests of the threaded stages with ThreadSanitizer in build-tsan/ and runs them on
# two threads: sampling (sample_test), extraction (extract_test), the whole run (pipeline_test,
# dist_test), decimation (decimate_test), compare (compare_test). Any report fails the run.
# Not part of CI (it takes long and needs the machine to itself); its findings are reported in
# docs/robustness.md.
# Usage: scripts/tsan.sh [gtest filter]   e.g. scripts/tsan.sh 'Decimate.*'
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
tests=(sample_test extract_test pipeline_test dist_test decimate_test compare_test)
start=$(date +%s)
cmake -S . -B build-tsan -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS="-fsanitize=thread -fno-omit-frame-pointer" \
  -DCMAKE_EXE_LINKER_FLAGS=-fsanitize=thread -DCMAKE_SHARED_LINKER_FLAGS=-fsanitize=thread \
  >/dev/null
cmake --build build-tsan -j "$(nproc)" --target "${tests[@]}" qjulia_cli
built=$(date +%s)

# TBB's scheduler lives in Debian's uninstrumented libtbb: the suppressions in
# scripts/sanitize/tsan.supp, each documented, cover what it hides from ThreadSanitizer.
export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$PWD/scripts/sanitize/tsan.supp"
status=0
for t in "${tests[@]}"; do
  t0=$(date +%s)
  if build-tsan/tests/"$t" --gtest_filter="${1:-*}" >"build-tsan/$t.log" 2>&1; then
    echo "tsan: $t passed ($(($(date +%s) - t0)) s)"
  else
    echo "tsan: $t FAILED ($(($(date +%s) - t0)) s), build-tsan/$t.log:" >&2
    grep -m 40 -A 30 "WARNING: ThreadSanitizer\|FAILED" "build-tsan/$t.log" >&2 || true
    status=1
  fi
done
end=$(date +%s)
echo "tsan: build $(((built - start) / 60)) min $(((built - start) % 60)) s, tests" \
  "$(((end - built) / 60)) min $(((end - built) % 60)) s"
exit $status
