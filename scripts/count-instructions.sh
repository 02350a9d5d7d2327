#!/usr/bin/env bash
# Instructions and (simulated) branch mispredicts of a CPU bench under cachegrind: deterministic
# figures for comparing two builds of the engine, where wall-clock timings on a shared VM
# scatter by tens of per cent. Needs valgrind (Debian: apt-get install valgrind). Valgrind
# emulates no AVX-512, so the contact lanes run their AVX2 build here.
# usage: scripts/count-instructions.sh [SCENE] [N] [STEPS] [SWEEP_BINARY] [--settle]
# With --settle the bed is settled (or the chute's flow developed) natively first and kept in
# target/bench-db/bench-beds/, so that valgrind times only the 100 + STEPS steps from it.
set -euo pipefail
scene=${1:-chute-bed}
n=${2:-30000}
steps=${3:-100}
bin=${4:-target/release/sweep}
settle=${5:-}
out=$(mktemp -d)
db="$out/bench.db"
if [ "$settle" = "--settle" ]; then
  mkdir -p target/bench-db
  db=target/bench-db/bench.db
  "$bin" bench --scene "$scene" --particles "$n" --steps 1 --settle --no-store --db "$db" \
    >/dev/null
fi
valgrind --tool=cachegrind --branch-sim=yes --cache-sim=no \
  --cachegrind-out-file="$out/cachegrind.out" \
  "$bin" bench --scene "$scene" --particles "$n" --steps "$steps" --backend cpu \
  --precision f32 --threads 1 --no-store --db "$db" $settle 2>&1 |
  grep -E "I +refs|Mispredicts|particle-steps/s"
rm -rf "$out"
