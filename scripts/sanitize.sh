#!/usr/bin/env bash
# Builds the test suite with AddressSanitizer + UndefinedBehaviorSanitizer in build-asan/
# (build type Sanitize) and runs it. Any sanitizer report fails the run: UBSan stops at the
# first error, ASan and LeakSanitizer make the process exit non-zero. Only the test executables
# and the CLI they run are built (no benchmarks).
# Usage: scripts/sanitize.sh [ctest arguments...]   e.g. scripts/sanitize.sh -R Render
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
start=$(date +%s)
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=Sanitize >/dev/null
cmake --build build-asan -j "$(nproc)" --target qjulia_tests
built=$(date +%s)

supp=$PWD/scripts/sanitize  # each suppression there is documented
export ASAN_OPTIONS="detect_leaks=1:check_initialization_order=1:strict_init_order=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"  # no UBSan suppression is needed
export LSAN_OPTIONS="suppressions=$supp/lsan.supp:print_suppressions=0"
# The signal tests time the CLI's exit to the second, and the estimate's accuracy and refusal
# tests measure peak memory against the Release build's figures (the sanitizers' shadow memory and quarantine
# are not the program's): properties of the Release build, tested there. The
# tests that run the library inside another program (Python, Blender, mpirun, a browser) are
# not built here: an instrumented module or binary needs the sanitizer runtime preloaded into
# an uninstrumented interpreter; the code they reach is run under the sanitizers by the gtest
# suites (dist_test runs the distributed stages with ranks as threads). The embedding check at
# 256 (a minute in Release, CGAL's exact predicates on millions of faces) is left to the Release
# run; the same code is run here by every other extraction test. The address-space test runs the
# CLI under ulimit -v, which an instrumented process cannot start under (its shadow memory is
# terabytes of address space). Every other test runs.
ctest --test-dir build-asan --output-on-failure -j "$(nproc)" \
  -E '^MeshStages/Signals\.|^Estimate\.PeakMemory|^Estimate\.RefusesWhatDoesNotFit|^Estimate\.AddressSpaceLimit|^Extract\.TheSurfaceIsEmbeddedOnEveryPreset$|^python_module$|^blender_addon|^mpi_same_files$|^explore_' "$@"
end=$(date +%s)
echo "sanitize: build $(((built - start) / 60)) min $(((built - start) % 60)) s, tests" \
  "$(((end - built) / 60)) min $(((end - built) % 60)) s"
