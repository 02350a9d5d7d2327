#!/usr/bin/env bash
# Builds sweep and runs the quick silo campaign (a few minutes on 2 cores), then draws fig3, fig4
# and the coarse-grained field figures fig6, fig10 and fig11 from the database.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release
./target/release/sweep launch campaigns/silo_QvsF_quick.json --db quick.db --parallel 2
./target/release/sweep report --figure fig3 --db quick.db --out figures
./target/release/sweep report --figure fig4 --db quick.db --out figures
for f in fig6 fig10 fig11; do
    ./target/release/sweep report --figure "$f" --db quick.db --out figures
done
