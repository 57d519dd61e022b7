#!/usr/bin/env bash
# Builds the tests of the threaded stages with ThreadSanitizer in build-tsan/ and runs them:
# sampling (sample_test), extraction (extract_test), the whole run (pipeline_test, dist_test),
# decimation (decimate_test), compare (compare_test). Any report fails the run.
# ThreadSanitizer sees only instrumented code, and TBB hands tasks between threads inside
# libtbb: with Debian's uninstrumented libtbb every parallel loop is reported as a race (the
# join is invisible). So the script builds libtbb itself with -fsanitize=thread from Debian's
# source of the installed version (deb.debian.org's pool, checked against the .dsc's SHA-256,
# Debian's patches applied) into build-tsan/tbb/, and the tests load it. No suppression.
# Not part of CI (about 20 minutes on two cores); the findings are in docs/robustness.md.
# Usage: scripts/tsan.sh [gtest filter]   e.g. scripts/tsan.sh 'Decimate.*'
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
start=$(date +%s)

# libtbb with ThreadSanitizer, from the source of the installed libtbb-dev.
version=$(dpkg-query -W -f='${Version}' libtbb-dev)  # e.g. 2021.8.0-2+deb12u1
upstream=${version%-*}
tbb=$PWD/build-tsan/tbb
if [[ ! -e $tbb/lib/libtbb.so.12 ]]; then
  mkdir -p "$tbb/src" && cd "$tbb/src"
  pool=http://deb.debian.org/debian/pool/main/o/onetbb
  curl -sSfO "$pool/onetbb_${version}.dsc"
  curl -sSfO "$pool/onetbb_${upstream}.orig.tar.xz"
  curl -sSfO "$pool/onetbb_${version}.debian.tar.xz"
  for f in "onetbb_${upstream}.orig.tar.xz" "onetbb_${version}.debian.tar.xz"; do
    want=$(awk -v f="$f" '/^Checksums-Sha256:/{on=1; next} /^[^ ]/{on=0} on && $3 == f {print $1}' \
      "onetbb_${version}.dsc")
    echo "$want  $f" | sha256sum -c --quiet ||
      { echo "tsan: $f does not match its .dsc" >&2; exit 1; }
  done
  rm -rf "oneTBB-${upstream}" && tar xf "onetbb_${upstream}.orig.tar.xz"
  tar xf "onetbb_${version}.debian.tar.xz" -C "oneTBB-${upstream}"
  (cd "oneTBB-${upstream}" && while read -r patch; do
    [[ -z $patch || $patch == \#* ]] || patch -s -p1 <"debian/patches/$patch"
  done <debian/patches/series)
  cmake -S "oneTBB-${upstream}" -B build -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTBB_SANITIZE=thread \
    -DTBB_TEST=OFF -DTBBMALLOC_BUILD=OFF -DTBB_STRICT=OFF >/dev/null
  cmake --build build -j "$(nproc)" --target tbb >/dev/null
  mkdir -p "$tbb/lib" && cp -a build/*/libtbb.so* "$tbb/lib/"
  cd - >/dev/null
fi
export LD_LIBRARY_PATH=$tbb/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}

tests=(sample_test extract_test pipeline_test dist_test decimate_test compare_test)
cmake -S . -B build-tsan -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS="-fsanitize=thread -fno-omit-frame-pointer" \
  -DCMAKE_EXE_LINKER_FLAGS=-fsanitize=thread -DCMAKE_SHARED_LINKER_FLAGS=-fsanitize=thread \
  >/dev/null
cmake --build build-tsan -j "$(nproc)" --target "${tests[@]}" qjulia_cli
built=$(date +%s)

export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1"
status=0
for t in "${tests[@]}"; do
  t0=$(date +%s)
  ldd build-tsan/tests/"$t" | grep -q "$tbb/lib/libtbb" ||
    { echo "tsan: $t does not load the instrumented libtbb" >&2; exit 1; }
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
