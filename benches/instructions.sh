#!/usr/bin/env bash
# Noise-free companion of the criterion benches (benches/step.rs): instructions per
# grain-step of the timed region of `mbs bench` (mbs::tools::bench::timed),
# counted by callgrind. Prepared beds are made natively first and kept in
# target/tmp/bench-beds (shared with the criterion benches), so valgrind only runs the timed repetitions.
#
# Usage: benches/instructions.sh [GRAINS...]   (default: 64 1024 16384 65536)
# Env:   CASES (default "still flow rebuild contacts"), PRECISIONS
#        (default "f64 f32"), BETAS (default "15.8 1"), STEPS (default 20).
set -euo pipefail
cd "$(dirname "$0")/.."
sizes=("${@:-64 1024 16384 65536}")
cases=${CASES:-still flow rebuild contacts}
precisions=${PRECISIONS:-f64 f32}
betas=${BETAS:-15.8 1}
steps=${STEPS:-20}
beds=target/tmp/bench-beds
cargo build --release -q -p mbs
mbs=target/release/mbs
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
printf "%-8s %-9s %-5s %-6s %14s %10s\n" grains precision beta case instr/grain contacts
for n in ${sizes[*]}; do
  for p in $precisions; do
    # f32 positions across the 3.1 m of the largest bed are too coarse to settle it.
    if [ "$p" = f32 ] && [ "$n" -gt 16384 ]; then continue; fi
    for beta in $betas; do
      for case in $cases; do
        args=(bench --quiet --grains "$n" --precision "$p" --beta "$beta" --case "$case" --beds "$beds")
        "$mbs" "${args[@]}" --steps 1 >/dev/null
        line=$(valgrind --tool=callgrind --callgrind-out-file="$out/cg" \
          --toggle-collect='mbs::tools::bench::timed*' "$mbs" "${args[@]}" --steps "$steps" 2>/dev/null)
        total=$(callgrind_annotate "$out/cg" 2>/dev/null | awk '/PROGRAM TOTALS/ {gsub(",", "", $1); print $1}')
        grains=$(sed -E 's/^([0-9]+) grains.*/\1/' <<<"$line")
        contacts=$(sed -E 's/.*, ([0-9.]+) contacts per grain.*/\1/' <<<"$line")
        printf "%-8s %-9s %-5s %-6s %14.1f %10s\n" "$grains" "$p" "$beta" "$case" \
          "$(awk -v t="$total" -v g="$grains" -v s="$steps" "BEGIN { print t / (g * s) }")" "$contacts"
      done
    done
  done
done
