#!/usr/bin/env bash
# What deciding a claim costs: campaigns/silo_claims_tiny.json (4 points, one compare claim on
# two of them) run to its verdict by the adaptive rounds and by a uniform design (every point
# run on equally each round), in one run. Particle-steps are the campaign's own, from
# `sweep status`; they do not depend on the machine (the CPU runs are bitwise deterministic).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q
sweep="$PWD/target/release/sweep"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
for alloc in adaptive uniform; do
    mkdir -p "$tmp/$alloc"
    sed "s/\"allocation\": \"adaptive\"/\"allocation\": \"$alloc\"/" \
        campaigns/silo_claims_tiny.json >"$tmp/$alloc/c.json"
    start=$(date +%s)
    "$sweep" launch "$tmp/$alloc/c.json" --db "$tmp/$alloc/s.db" --backend cpu >"$tmp/$alloc/log" 2>&1
    end=$(date +%s)
    echo "== $alloc ($((end - start)) s wall)"
    "$sweep" status --db "$tmp/$alloc/s.db" | grep -E '^claims|^  q_ratio|^target'
done
