#!/usr/bin/env bash
# Builds sweep and runs the quick chute campaign (about 5 minutes on 2 cores), then draws the
# chute paper's figures 2-7 from the database.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release
./target/release/sweep launch campaigns/chute_DvsShear_quick.json --db quick_chute.db --parallel 2
for f in fig2 fig3 fig4 fig5 fig6 fig7; do
    ./target/release/sweep report --figure "$f" --db quick_chute.db --out figures
done
