#!/usr/bin/env bash
# The test command (README): installs what the tests need, then runs every test in release mode.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --release --workspace --all-targets "$@"
