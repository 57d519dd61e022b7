#!/usr/bin/env bash
# qjulia-mpi against qjulia: for 1, 2 and 3 ranks, `mpirun -n K qjulia-mpi mesh ARGS` writes the
# files `qjulia mesh ARGS` writes, byte for byte, in every case below; bad input exits 2 with one message;
# --vdb is refused with exit 2; --stats lists every rank; SIGINT or SIGTERM to mpirun and a rank
# failing mid-run end the job non-zero with no file.
# usage: mpi_test.sh QJULIA QJULIA_MPI MPIEXEC
set -euo pipefail
qjulia=$1 qjulia_mpi=$2 mpiexec=$3
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
mpi() { local k=$1; shift; "$mpiexec" -n "$k" "$qjulia_mpi" "$@"; }

same_dir() {  # DIR1 DIR2: the same files with the same bytes
  diff -r "$1" "$2" >/dev/null
}

same_file() {  # NAME EXT ARGS...: one process vs 1, 2, 3 ranks (or $ranks), every file written
  local name=$1 ext=$2 k; shift 2
  mkdir -p "$work/$name/one"
  "$qjulia" mesh "$@" --quiet --threads 1 -o "$work/$name/one/m.$ext" >/dev/null
  for k in ${ranks:-1 2 3}; do
    mkdir "$work/$name/$k"
    mpi "$k" mesh "$@" --quiet --threads 1 -o "$work/$name/$k/m.$ext" >"$work/out" 2>&1 ||
      { cat "$work/out"; fail "$name on $k ranks exited $?"; }
    same_dir "$work/$name/one" "$work/$name/$k" ||
      fail "$name: $k ranks wrote other files than one process"
  done
  echo "ok: $name ($ext) identical for ${ranks:-1 2 3} ranks"
}

same_file newton-ply ply --resolution 64
same_file rosa-stl stl --preset rosa-rational --resolution 64
same_file classic-clip-colour ply --preset classic-julia --resolution 64 --clip 1,0.3,0,0.2 \
  --color iterations
same_file newton-min-component ply --resolution 64 --min-component 0.001 --color basin
same_file newton-faces ply --resolution 48 --faces 3000
same_file newton-glb glb --resolution 48
same_file sine-obj obj --preset sine-julia --resolution 64
same_file newton-3mf 3mf --resolution 48
same_file classic-3mf 3mf --preset classic-julia --resolution 48
same_file rosa-faces-gltf gltf --preset rosa-rational --resolution 48 --faces 4000 \
  --min-component 0.01
same_file rosa-clip-min-component ply --preset rosa-rational --resolution 48 --clip 0,1,0,0.5 \
  --min-component 0.01
same_file classic-check ply --preset classic-julia --resolution 40 --check
ranks=2 same_file classic-thickness ply --preset classic-julia --resolution 32 --size 10mm \
  --min-thickness 0.3mm

# Threads: 2 ranks of 2 threads each decimate to the file of one process on one thread.
"$qjulia" mesh --resolution 48 --faces 3000 --quiet --threads 1 -o "$work/t1.ply" >/dev/null
mpi 2 mesh --resolution 48 --faces 3000 --quiet --threads 2 -o "$work/t2.ply" >/dev/null
cmp -s "$work/t1.ply" "$work/t2.ply" || fail "--faces on 2 ranks of 2 threads differs"
echo "ok: --faces on 2 ranks of 2 threads"

# --stats: every rank's figures and the imbalance.
mpi 2 mesh --resolution 48 --quiet -o "$work/s.ply" --stats "$work/s.json" >/dev/null
/usr/bin/python3 - "$work/s.json" <<'PY' || fail "stats"
import json, sys
s = json.load(open(sys.argv[1]))
assert len(s["ranks"]) == 2, s.get("ranks")
assert all(r["bricks"] > 0 and r["evaluations"] > 0 for r in s["ranks"]), s["ranks"]
assert s["load_imbalance"] >= 1.0 and s["gathered"] is False, s
assert s["total_evaluations"] == sum(r["evaluations"] for r in s["ranks"]), s
PY
echo "ok: --stats lists both ranks"

# A preview needs the whole mesh: gathered, and the same picture.
"$qjulia" mesh --resolution 40 --quiet -o "$work/p1.ply" --preview "$work/p1.png" >/dev/null
mpi 2 mesh --resolution 40 --quiet -o "$work/p2.ply" --preview "$work/p2.png" >/dev/null
cmp -s "$work/p1.png" "$work/p2.png" || fail "preview differs"
cmp -s "$work/p1.ply" "$work/p2.ply" || fail "mesh with preview differs"
echo "ok: --preview on 2 ranks"

# The version: one line, the library's, as `qjulia version` prints it; an argument exits 2.
[ "$(mpi 2 version)" = "$("$qjulia" version | sed 's/^qjulia /qjulia-mpi /')" ] || fail "version"
set +e
mpi 1 version extra >/dev/null 2>"$work/err"
code=$?
set -e
[ "$code" = 2 ] || fail "version with an argument exited $code"
echo "ok: version"

# Bad input: exit 2, one message, nothing written.
set +e
mpi 3 mesh --formula "h^^2" -o "$work/bad.ply" >"$work/out" 2>"$work/err"
code=$?
set -e
[ "$code" = 2 ] || fail "bad formula exited $code"
[ "$(grep -c "^qjulia-mpi mesh:.*formula" "$work/err")" = 1 ] || { cat "$work/err"; fail "the message is not printed once"; }
[ ! -e "$work/bad.ply" ] || fail "a file was written for bad input"
set +e
mpi 2 mesh --resolution 32 -o "$work/v.ply" --vdb "$work/v.vdb" >"$work/out" 2>"$work/err"
code=$?
set -e
[ "$code" = 2 ] || fail "--vdb exited $code"
grep -q -- "--vdb is not available across ranks" "$work/err" || { cat "$work/err"; fail "--vdb message"; }
[ "$(grep -c "^qjulia-mpi mesh:" "$work/err")" = 1 ] || { cat "$work/err"; fail "the --vdb message is not printed once"; }
[ ! -e "$work/v.ply" ] && [ ! -e "$work/v.vdb" ] || fail "files written despite --vdb refusal"
echo "ok: bad input and --vdb exit 2 with one message"
# SIGINT or SIGTERM to mpirun during a long run: every rank stops, the job exits non-zero, no
# file. (At 512 two ranks can finish within the 2 s before the signal on a fast host; 1024 takes
# four times as long.)
for signal in INT TERM; do
  rm -rf "$work/sig" && mkdir "$work/sig"
  "$mpiexec" -n 2 "$qjulia_mpi" mesh --resolution 1024 --threads 1 --quiet -o "$work/sig/big.ply" \
    --stats "$work/sig/big.json" >"$work/sig.out" 2>&1 &
  job=$!
  sleep 2
  kill -"$signal" "$job"
  set +e
  wait "$job"
  code=$?
  set -e
  [ "$code" != 0 ] || fail "the job interrupted by SIG$signal exited 0"
  [ -z "$(ls -A "$work/sig")" ] || fail "the job interrupted by SIG$signal left $(ls -A "$work/sig")"
  grep -q "interrupted" "$work/sig.out" || { cat "$work/sig.out"; fail "no interruption message"; }
  echo "ok: SIG$signal to mpirun ends every rank (exit $code), no file left"
done

# A rank failing mid-run: rank 1 runs out of address space (its limit is set below the run's
# need, about 450 MB, but above what MPI needs to start, more than 250 MB with malloc on huge pages:
# below that a rank can stop inside MPI_Init), the job exits non-zero, no file.
rm -rf "$work/sig" && mkdir "$work/sig"
set +e
"$mpiexec" -n 1 "$qjulia_mpi" mesh --resolution 512 --threads 1 --quiet -o "$work/sig/big.ply" \
  : -n 1 sh -c 'ulimit -v 350000 && exec "$0" "$@"' "$qjulia_mpi" mesh --resolution 512 \
  --threads 1 --quiet -o "$work/sig/big.ply" >"$work/fail.out" 2>&1
code=$?
set -e
[ "$code" != 0 ] || fail "the job with a failing rank exited 0"
grep -q "error on rank 1: out of memory (peak " "$work/fail.out" || { cat "$work/fail.out"; fail "no message from rank 1"; }
[ -z "$(ls -A "$work/sig")" ] || fail "the job with a failing rank left $(ls -A "$work/sig")"
echo "ok: a rank failing mid-run ends the job (exit $code), no file left"
left=$(find "$work" -name "*tmp-*")
[ -z "$left" ] || fail "a temporary file was left: $left"
echo "qjulia-mpi: all checks passed"
