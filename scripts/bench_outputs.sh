#!/usr/bin/env bash
# File sizes and write rates (points per second of writer time) of every
# point format for the built-in demo: runs benches/outputs.rs. Takes a few
# minutes (the demo is simulated once per format). Not part of the test
# suite.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo bench -p lidarsim-bench --bench outputs --quiet
