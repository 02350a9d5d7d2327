#!/usr/bin/env bash
# Alternates two sweep binaries on the same settled beds (f32, 2 threads) and prints every run:
#   bash scripts/compare-builds.sh OLD_BIN NEW_BIN [N] [STEPS] [ROUNDS]
#   SCENES="chute-rods chute-bed" bash scripts/compare-builds.sh ...   (default: chute-bed silo-bed)
# Both use the beds kept in ./bench-beds (made by the first run's --settle), so they time the same
# state (chute-rods has no settled bed: it starts from its lattice); equal checksums say they
# computed the same bits. Compare the ratio of medians, not the
# absolute figures (this VM's speed drifts 20-40 % over minutes).
set -euo pipefail
old=$1 new=$2 n=${3:-30000} steps=${4:-300} rounds=${5:-4}
scenes=${SCENES:-chute-bed silo-bed}
for r in $(seq "$rounds"); do
  for bin in "$old" "$new"; do
    for scene in $scenes; do
      settle=--settle
      [ "$scene" = chute-rods ] && settle=
      line=$("$bin" bench --scene "$scene" $settle --particles "$n" --steps "$steps" \
        --precision f32 --threads 2 --no-store 2>&1 | grep "particle-steps/s" | tail -1)
      echo "round $r  $bin  $line"
    done
  done
done
