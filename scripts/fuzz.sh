#!/usr/bin/env bash
# Builds the libFuzzer targets (clang-16, ASan+UBSan; tests/fuzz/CMakeLists.txt) in build-fuzz/
# and runs every target: first the committed corpus tests/fuzz/corpus/TARGET and the inputs that
# once failed (tests/fuzz/regressions/TARGET) once, then a fixed number of fuzzing runs with a
# fixed seed (-seed=1 -runs=N), so CI is deterministic. New inputs go to build-fuzz/corpus/TARGET
# (emptied first; the committed corpus is left as it is), crashes to build-fuzz/artifacts/.
# Fails on the first crash, leak, timeout or sanitizer report.
#
# Usage: scripts/fuzz.sh [TARGET...]        (default: every target)
#   FUZZ_SCALE=10 scripts/fuzz.sh obj        ten times the runs (a longer search)
#   FUZZ_DETERMINISTIC=0 scripts/fuzz.sh     with -use_cmp and address-space randomization
#                                            (a better search, not repeatable)
#   FUZZ_ONLY_BUILD=1 scripts/fuzz.sh        build only
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD

# Runs per target: 20 to 30 s each on the 2-core machine at a load of 2 to 3 (measured; see
# docs/robustness.md). The 3MF reader is slow per input (libzip, then lib3mf).
declare -A runs=(
  [formula_fuzz]=250000 [params_fuzz]=250000
  [mesh_ply_ascii_fuzz]=350000 [mesh_ply_binary_le_fuzz]=350000 [mesh_ply_binary_be_fuzz]=350000
  [mesh_obj_fuzz]=300000 [mesh_stl_ascii_fuzz]=330000 [mesh_stl_binary_fuzz]=350000
  [mesh_gltf_fuzz]=80000 [mesh_glb_fuzz]=100000 [mesh_3mf_fuzz]=10000)
declare -A corpus=(
  [formula_fuzz]=formula [params_fuzz]=params [mesh_ply_ascii_fuzz]=ply_ascii
  [mesh_ply_binary_le_fuzz]=ply_binary_le [mesh_ply_binary_be_fuzz]=ply_binary_be
  [mesh_obj_fuzz]=obj [mesh_stl_ascii_fuzz]=stl_ascii [mesh_stl_binary_fuzz]=stl_binary
  [mesh_gltf_fuzz]=gltf [mesh_glb_fuzz]=glb [mesh_3mf_fuzz]=3mf)
declare -A dict=(
  [formula_fuzz]=formula [params_fuzz]=params [mesh_ply_ascii_fuzz]=ply
  [mesh_ply_binary_le_fuzz]=ply [mesh_ply_binary_be_fuzz]=ply [mesh_obj_fuzz]=obj
  [mesh_stl_ascii_fuzz]=stl [mesh_gltf_fuzz]=gltf [mesh_glb_fuzz]=gltf)
order=(formula_fuzz params_fuzz mesh_ply_ascii_fuzz mesh_ply_binary_le_fuzz
  mesh_ply_binary_be_fuzz mesh_obj_fuzz mesh_stl_ascii_fuzz mesh_stl_binary_fuzz mesh_gltf_fuzz
  mesh_glb_fuzz mesh_3mf_fuzz)
targets=("${@:-${order[@]}}")
scale=${FUZZ_SCALE:-1}

command -v clang++-16 >/dev/null || { echo "fuzz: clang++-16 is missing (scripts/setup.sh)" >&2; exit 1; }
cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=clang++-16 \
  -DQJULIA_BUILD_FUZZERS=ON >/dev/null
cmake --build build-fuzz -j "$(nproc)" --target fuzzers
[[ -n "${FUZZ_ONLY_BUILD:-}" ]] && exit 0

# Sanitizers stop at the first report; leaks count. Suppressions: tests/fuzz/lsan.supp.
export ASAN_OPTIONS=abort_on_error=1:detect_leaks=1:allocator_may_return_null=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export LSAN_OPTIONS=suppressions=$root/tests/fuzz/lsan.supp:print_suppressions=0
# Suppressions match function names: reports must be symbolized (llvm-16, scripts/setup.sh).
symbolizer=$(command -v /usr/lib/llvm-16/bin/llvm-symbolizer llvm-symbolizer-16 llvm-symbolizer |
  head -n 1 || true)
[[ -n "$symbolizer" ]] ||
  { echo "fuzz: llvm-symbolizer is missing (scripts/setup.sh installs llvm-16)" >&2; exit 1; }
export ASAN_SYMBOLIZER_PATH=$symbolizer
asan=$ASAN_OPTIONS
deterministic=${FUZZ_DETERMINISTIC:-1}
run=()
[[ $deterministic == 1 ]] && run=(setarch "$(uname -m)" -R)  # no address-space randomization

mkdir -p build-fuzz/artifacts
for t in "${targets[@]}"; do
  [[ -n "${corpus[$t]:-}" ]] || { echo "fuzz: unknown target $t (${order[*]})" >&2; exit 2; }
  exe=build-fuzz/tests/fuzz/$t
  seeds=tests/fuzz/corpus/${corpus[$t]}
  work=build-fuzz/corpus/${corpus[$t]}
  rm -rf "$work" && mkdir -p "$work"  # every run starts from the committed corpus alone
  flags=(-seed=1 -timeout=10 -rss_limit_mb=2048 -max_len=65536 -print_final_stats=1
    -artifact_prefix="build-fuzz/artifacts/$t-")
  # Determinism: libFuzzer feeds the operands of comparisons into its mutations (-use_cmp),
  # pointers among them, whose values change from run to run even with address-space
  # randomization off; with both off, two runs explore the same inputs (checked).
  [[ $deterministic == 1 ]] && flags+=(-use_cmp=0)
  [[ -n "${dict[$t]:-}" ]] && flags+=(-dict="tests/fuzz/${dict[$t]}.dict")
  n=$((runs[$t] * scale))
  # lib3mf leaks on every read (tests/fuzz/lsan.supp): the 3MF target fuzzes without leak
  # checks and checks leaks on every input of the corpus before and after, with the full stack
  # (lib3mf has no frame pointers), so the suppressions match lib3mf's functions only.
  replay_asan=$asan fuzz_asan=$asan
  if [[ $t == mesh_3mf_fuzz ]]; then
    replay_asan=$asan:fast_unwind_on_malloc=0
    fuzz_asan=${asan/detect_leaks=1/detect_leaks=0}
  fi
  echo "== $t: replay $seeds, then $n runs" >&2
  start=$SECONDS
  replay=("$seeds")
  [[ -d tests/fuzz/regressions/${corpus[$t]} ]] && replay+=("tests/fuzz/regressions/${corpus[$t]}")
  ASAN_OPTIONS=$replay_asan "${run[@]}" "$exe" "${flags[@]}" -runs=0 "${replay[@]}" \
    2>"build-fuzz/$t.replay.log" || { cat "build-fuzz/$t.replay.log" >&2; exit 1; }
  ASAN_OPTIONS=$fuzz_asan "${run[@]}" "$exe" "${flags[@]}" -runs="$n" "$work" "$seeds" \
    2>"build-fuzz/$t.log" ||
    { tail -n 60 "build-fuzz/$t.log" >&2; exit 1; }
  if [[ $t == mesh_3mf_fuzz ]]; then
    ASAN_OPTIONS=$replay_asan "${run[@]}" "$exe" "${flags[@]}" -runs=0 "$work" \
      2>"build-fuzz/$t.leaks.log" ||
      { tail -n 60 "build-fuzz/$t.leaks.log" >&2; exit 1; }
  fi
  stats=$(grep -E "^stat::number_of_executed_units|^#[0-9]+.*(DONE|cov)" "build-fuzz/$t.log" | tail -2 | tr '\n' ' ')
  echo "   $t: $((SECONDS - start)) s; $stats" >&2
done
