#!/usr/bin/env bash
# mbs against LAMMPS on the same settled bed, one core each, alternating
# runs: the bed of `mbs bench --case still` written as a LAMMPS data file
# and input by `host/examples/lammps.rs` (gran/hooke/history with mbs's
# constants, step and skin; docs/performance.md, "Against LAMMPS").
#
#   bash benches/lammps.sh [GRAINS] [STEPS] [RUNS]    (16368 1000 5)
#
# Needs LAMMPS with its GRANULAR package on the PATH as `lmp` (Debian:
# apt-get install lammps). Prints each run's ns per grain-step of both,
# the medians and their ratio.
set -euo pipefail
cd "$(dirname "$0")/.."
grains=${1:-16368}
steps=${2:-1000}
runs=${3:-5}
command -v lmp > /dev/null || { echo "needs LAMMPS as lmp (Debian: apt-get install lammps)" >&2; exit 2; }
export OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
cargo build --release -q -p mbs --bin mbs --example lammps
beds=target/tmp/bench-beds
dir=target/tmp/lammps-$grains
./target/release/examples/lammps "$grains" "$dir" "$beds"
ours=() theirs=()
for run in $(seq "$runs"); do
  ns=$(./target/release/mbs bench --grains "$grains" --case still --threads 1 \
    --steps "$steps" --beds "$beds" | sed -n 's/.*still: \([0-9.]*\) ns per grain-step.*/\1/p')
  ours+=("$ns")
  (cd "$dir" && lmp -in in.bed -var steps "$steps" -log none -screen lammps.out)
  loop=$(sed -n 's/^Loop time of \([0-9.e+-]*\) on 1 procs for \([0-9]*\) steps with \([0-9]*\) atoms.*/\1 \2 \3/p' "$dir/lammps.out")
  ns=$(echo "$loop" | awk '{ printf "%.1f", $1 / ($2 * $3) * 1e9 }')
  theirs+=("$ns")
  echo "run $run: mbs ${ours[-1]} ns, LAMMPS $ns ns per grain-step"
done
median() { printf '%s\n' "$@" | sort -g | awk '{ a[NR] = $1 } END { print a[int((NR + 1) / 2)] }'; }
m_ours=$(median "${ours[@]}")
m_theirs=$(median "${theirs[@]}")
echo "median: mbs $m_ours, LAMMPS $m_theirs ns per grain-step ($grains grains, one core):" \
  "$(awk -v a="$m_theirs" -v b="$m_ours" 'BEGIN { printf "%.1f", a / b }')x"
grep -E "^ +0 |^ +$steps " "$dir/lammps.out" |
  sed 's/^/LAMMPS step, kinetic energy (J), contacts per grain: /'
