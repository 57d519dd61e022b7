#!/usr/bin/env bash
# Measures the speed targets of README's table side by side, alternating the two commands of
# each pair so that both see the same state of a shared, noisy machine; prints every run, the
# medians and their ratio, and the median of the pairs' ratios.
#
#   scripts/targets.sh peer [N] [ROUNDS]       classic-julia at N (256) on one thread, PLY
#                                              written, against Mandelbulber2 on the same set
#                                              (../shared/peer/mandelbulber_mesh.sh, iter mode);
#                                              ROUNDS (5) alternations
#   scripts/targets.sh threads [N] [PAIRS] [PRESET]
#                                              PRESET (newton-cubic) at N (512), PLY written, on
#                                              one thread against two; PAIRS (8) alternations
#
# QJULIA names the binary (default build/bin/qjulia), PEER the peer's script (default
# ../shared/peer/mandelbulber_mesh.sh beside the repository). Wall times of whole commands, as
# README reports them. Each command replaces its previous output file, in a temporary folder
# that is removed at the end.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
qjulia=${QJULIA:-$root/build/bin/qjulia}
peer=${PEER:-$root/../shared/peer/mandelbulber_mesh.sh}

usage() {
  sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
}

# A positive integer argument, or the default.
count() {
  local value=${1:-$2}
  [[ $value =~ ^[1-9][0-9]*$ ]] || {
    echo "targets: expected a positive integer, not '$value'" >&2
    exit 2
  }
  echo "$value"
}

[[ -x $qjulia ]] || {
  echo "targets: $qjulia is not built (scripts/build.sh builds it; QJULIA names another)" >&2
  exit 1
}

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# Runs a command with its output discarded; prints its wall time in seconds. A failing command
# stops the measurement with its error.
wall() {
  local start end
  start=$EPOCHREALTIME
  if ! "$@" >"$work/log" 2>&1; then
    echo "targets: failed: $*" >&2
    tail -n 5 "$work/log" >&2
    exit 1
  fi
  end=$EPOCHREALTIME
  awk -v a="$start" -v b="$end" 'BEGIN { printf "%.3f\n", b - a }'
}

# The median of the numbers on standard input, one a line.
median() {
  sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'
}

# Prints the medians of the two columns of times (labelled $1 and $2), the ratio of column $3's
# median to the other's, and the median of the pairs' ratios taken the same way.
summary() {
  local labels=("$1" "$2") num=$3 den=$((3 - $3))
  local m1 m2 ratio pairs
  m1=$(cut -f1 "$work/times" | median)
  m2=$(cut -f2 "$work/times" | median)
  ratio=$(awk -v n="$num" -v a="$m1" -v b="$m2" 'BEGIN { print n == 1 ? a / b : b / a }')
  pairs=$(awk -v n="$num" -v d="$den" '{ printf "%.4f\n", $n / $d }' "$work/times" | median)
  printf 'median: %s %.3f s, %s %.3f s: %.2fx by the medians, %.2fx by the median of the pairs\n' \
    "${labels[0]}" "$m1" "${labels[1]}" "$m2" "$ratio" "$pairs"
}

case "${1:-}" in
  peer)
    n=$(count "${2:-}" 256)
    rounds=$(count "${3:-}" 5)
    [[ -x $peer ]] || {
      echo "targets: the peer's script $peer is missing (PEER names it)" >&2
      exit 1
    }
    command -v mandelbulber2 >/dev/null || {
      echo "targets: mandelbulber2 is not installed (apt-get install mandelbulber2 time)" >&2
      exit 1
    }
    echo "classic-julia at $n, one thread, PLY: qjulia against Mandelbulber2 (iter mode), $rounds rounds"
    : >"$work/times"
    for ((i = 1; i <= rounds; ++i)); do
      q=$(wall "$qjulia" mesh --preset classic-julia --resolution "$n" --threads 1 --quiet \
        -o "$work/q.ply")
      p=$(MB_MODE=iter wall "$peer" -0.2 0.8 0 0 "$n" 10 4 -1.5 1.5 "$work/p.ply")
      printf '%s\t%s\n' "$q" "$p" >>"$work/times"
      echo "round $i: qjulia $q s, Mandelbulber2 $p s"
    done
    summary qjulia Mandelbulber2 2
    ;;
  threads)
    n=$(count "${2:-}" 512)
    pairs=$(count "${3:-}" 8)
    preset=${4:-newton-cubic}
    echo "$preset at $n, PLY: one thread against two, $pairs pairs"
    : >"$work/times"
    for ((i = 1; i <= pairs; ++i)); do
      one=$(wall "$qjulia" mesh --preset "$preset" --resolution "$n" --threads 1 --quiet \
        -o "$work/t.ply")
      two=$(wall "$qjulia" mesh --preset "$preset" --resolution "$n" --threads 2 --quiet \
        -o "$work/t.ply")
      printf '%s\t%s\n' "$one" "$two" >>"$work/times"
      echo "pair $i: one thread $one s, two $two s"
    done
    summary "one thread" "two threads" 1
    ;;
  *) usage ;;
esac
