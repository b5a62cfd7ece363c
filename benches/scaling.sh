#!/usr/bin/env bash
# One bed on several cores: `mbs bench` on 1, 2, … threads in alternating
# rounds, each case's median of the rounds' medians (range of medians) in
# ns per grain-step (per grain and rebuild for `rebuild`) and the speed-up
# over one thread (docs/performance.md, "One bed on several cores").
#
#   bash benches/scaling.sh [MBS] [BEDS] [ROUNDS] [THREADS...]
#
# Defaults: target/release/mbs, target/tmp/bench-beds (prepared by a first
# `mbs bench`, about a minute per size; kept), 5 rounds, threads "1 2 and
# every core". CASES="GRAINS:CASE:STEPS ..." picks the cases (default: 65 k
# and 16 k grains, settled and flowing, and the 16 k rebuild). Builds
# nothing, so that a copied binary and beds run it on another machine.
set -euo pipefail
mbs=${1:-target/release/mbs}
beds=${2:-target/tmp/bench-beds}
rounds=${3:-5}
shift $(($# < 3 ? $# : 3))
cores=$(nproc)
threads=("$@")
[ ${#threads[@]} -gt 0 ] || threads=(1 2 "$cores")
cases=${CASES:-"65536:still:300 65536:flow:300 16384:still:1000 16384:flow:1000 16384:rebuild:1000"}
[ -x "$mbs" ] || { echo "no mbs binary at $mbs (cargo build --release -p mbs)" >&2; exit 2; }
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
median() { printf '%s\n' "$@" | sort -g | awk '{ a[NR] = $1 } END { print a[int((NR + 1) / 2)] }'; }
echo "| grains | case | threads | ns, median (range) | speed-up |"
echo "|---|---|---|---|---|"
for c in $cases; do
  IFS=: read -r grains case steps <<< "$c"
  declare -A runs=()
  for _ in $(seq "$rounds"); do
    for t in "${threads[@]}"; do
      ns=$("$mbs" bench --grains "$grains" --case "$case" --threads "$t" --steps "$steps" \
        --beds "$beds" | sed -n 's/.*median \([0-9.]*\),.*/\1/p')
      runs[$t]="${runs[$t]:-} $ns"
    done
  done
  one=""
  for t in "${threads[@]}"; do
    # shellcheck disable=SC2086
    m=$(median ${runs[$t]})
    # shellcheck disable=SC2086
    range=$(printf '%s\n' ${runs[$t]} | sort -g | awk 'NR == 1 { a = $1 } { b = $1 } END { printf "%s–%s", a, b }')
    [ -n "$one" ] || one=$m
    speedup=$(awk -v a="$one" -v b="$m" 'BEGIN { printf "%.2f", a / b }')
    echo "| $grains | $case | $t | $m ($range) | ${speedup}× |"
  done
  unset runs
done
