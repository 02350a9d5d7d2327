#!/usr/bin/env bash
# Regenerates docs/figures/ from the quick campaigns, so that the figures in the docs are the ones
# this build draws: builds sweep, runs the quick silo and chute campaigns into a fresh scratch
# directory (about 5 + 10 minutes on 2 cores), draws every figure of each with
# `sweep report --figure all`, and copies the PNGs to docs/figures/ as silo_figN.png and
# chute_figN.png (the index pages stay in the scratch directory, printed at the end).
# Usage: bash scripts/docs-figures.sh [SCRATCH_DIR]   (default: a new temporary directory)
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
scratch=${1:-$(mktemp -d -t sweep-docs-figures.XXXXXX)}
mkdir -p "$scratch"
cargo build --release
sweep="$root/target/release/sweep"
for scene in silo chute; do
    case $scene in
        silo) campaign=campaigns/silo_QvsF_quick.json ;;
        chute) campaign=campaigns/chute_DvsShear_quick.json ;;
    esac
    db="$scratch/$scene.db"
    "$sweep" launch "$campaign" --db "$db" --parallel 2
    "$sweep" report --figure all --db "$db" --out "$scratch/$scene"
done
mkdir -p docs/figures
rm -f docs/figures/silo_*.png docs/figures/chute_*.png
for f in "$scratch"/silo/fig*.png; do cp "$f" "docs/figures/silo_$(basename "$f")"; done
for f in "$scratch"/chute/chute_fig*.png; do cp "$f" "docs/figures/$(basename "$f")"; done
ls docs/figures
echo "index pages: $scratch/silo/index.html $scratch/chute/index.html"
