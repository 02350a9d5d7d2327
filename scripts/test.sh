#!/usr/bin/env bash
# The project's test command (README.md): every test, release mode (the physics tests integrate
# thousands of steps), with the test threads limited to the machine's cores.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --release -- --test-threads="$(nproc)"
