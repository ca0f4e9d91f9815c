#!/usr/bin/env bash
# The whole test suite, as CI runs it (.ci/run calls this script).
# Needs only the Rust toolchain and python3; the Python packages of the
# independent LAS check and of the lidarsim package's tests are installed
# into target/pyenv by check_las.sh and check_python.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
# Each step's heading says how long the suite has run so far.
step() { echo "== $1 (at $((SECONDS / 60))m$((SECONDS % 60))s)"; }

step "cargo fmt --check"
cargo fmt --all --check
step "cargo clippy"
cargo clippy --all-targets --quiet -- -D warnings
step "cargo doc"
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --quiet
step "module layers: no import cycle, no long file without a reason"
python3 scripts/check_layers.py
step "cargo test"
cargo test --quiet
step "portable build (-C target-cpu=x86-64): the scalar kernels' tests and the binary"
# The scalar twins of the SIMD kernels are what this build runs: their
# tests here, and the demo's bytes against the x86-64-v3 build's below
# (check_portable.sh). The rest of the suite does not depend on the
# processor's instructions and ran above.
CARGO_TARGET_DIR=target/portable RUSTFLAGS="-C target-cpu=x86-64" \
  cargo test --quiet -p lidarsim --lib kernels
CARGO_TARGET_DIR=target/portable RUSTFLAGS="-C target-cpu=x86-64" \
  cargo build --quiet --release -p lidarsim-cli
step "demo + independent LAS check (laspy)"
scripts/check_las.sh
step "the Python package: wheel (maturin) and its tests (pytest)"
scripts/check_python.sh
step "the scalar kernels write the same bytes as the AVX2 kernels"
scripts/check_portable.sh
step "memory stays flat in flight length; 100 M pulses in 1 GiB"
python3 scripts/check_memory.py target/release/lidarsim
step "all checks passed"
