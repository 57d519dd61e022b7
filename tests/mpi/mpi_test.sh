#!/usr/bin/env bash
# qjulia-mpi against qjulia: for 1, 2 and 3 ranks, `mpirun -n K qjulia-mpi mesh ARGS` writes the
# file `qjulia mesh ARGS` writes, byte for byte, in every case below; bad input exits 2 with one
# message; --vdb is refused with exit 2; --stats lists every rank.
# usage: mpi_test.sh QJULIA QJULIA_MPI MPIEXEC
set -euo pipefail
qjulia=$1 qjulia_mpi=$2 mpiexec=$3
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
mpi() { local k=$1; shift; "$mpiexec" -n "$k" "$qjulia_mpi" "$@"; }

same_file() {  # NAME EXT ARGS...: one process vs 1, 2, 3 ranks
  local name=$1 ext=$2; shift 2
  "$qjulia" mesh "$@" --quiet --threads 1 -o "$work/$name.one.$ext" >/dev/null
  for k in 1 2 3; do
    mpi "$k" mesh "$@" --quiet --threads 1 -o "$work/$name.$k.$ext" >"$work/out" 2>&1 ||
      { cat "$work/out"; fail "$name on $k ranks exited $?"; }
    cmp -s "$work/$name.one.$ext" "$work/$name.$k.$ext" ||
      fail "$name: $k ranks wrote another file than one process"
    if [ "$ext" = stl ]; then
      cmp -s "$work/$name.one.$ext.json" "$work/$name.$k.$ext.json" || fail "$name: sidecar"
    fi
  done
  echo "ok: $name ($ext) identical for 1, 2, 3 ranks"
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
# SIGINT to mpirun during a long run: every rank stops, the job exits non-zero, no file.
mkdir "$work/sig"
"$mpiexec" -n 2 "$qjulia_mpi" mesh --resolution 512 --threads 1 --quiet -o "$work/sig/big.ply" \
  --stats "$work/sig/big.json" >"$work/sig.out" 2>&1 &
job=$!
sleep 2
kill -INT "$job"
set +e
wait "$job"
code=$?
set -e
[ "$code" != 0 ] || fail "the interrupted job exited 0"
[ -z "$(ls -A "$work/sig")" ] || fail "the interrupted job left $(ls -A "$work/sig")"
grep -q "interrupted" "$work/sig.out" || { cat "$work/sig.out"; fail "no interruption message"; }
echo "ok: SIGINT to mpirun ends every rank (exit $code), no file left"
ls -A "$work" | grep -q "tmp-" && fail "a temporary file was left: $(ls -A "$work")"
echo "qjulia-mpi: all checks passed"
