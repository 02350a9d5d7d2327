#!/usr/bin/env bash
# The long tier of the tests: physics checks that take minutes each on 2 cores (the silo's
# Beverloo fit over four orifices, clogging statistics at rest and rotating; on the GPU, a rod
# chute against four CPU realisations, rods dropped to rest, a silo's Q against the CPU's
# interval, and 10⁵ particles run twice to the same bits). They are marked #[ignore] so that the test command
# (scripts/test.sh, run by CI) stays within CI's time; run them after any change to the engine,
# a scene or an observer, and before a release.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --release -- --ignored --test-threads="$(nproc)"
