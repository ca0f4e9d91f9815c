#!/usr/bin/env bash
# The whole test suite, as CI runs it (.ci/run calls this script).
# Needs only the Rust toolchain and python3; the Python packages of the
# independent LAS check and of the lidarsim package's tests are installed
# into target/pyenv by check_las.sh and check_python.sh.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== cargo fmt --check"
cargo fmt --all --check
echo "== cargo clippy"
cargo clippy --all-targets --quiet -- -D warnings
echo "== cargo doc"
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --quiet
echo "== module layers: no import cycle, no long file without a reason"
python3 scripts/check_layers.py
echo "== cargo test"
cargo test --quiet
echo "== cargo test, portable build (-C target-cpu=x86-64: the scalar kernels)"
CARGO_TARGET_DIR=target/portable RUSTFLAGS="-C target-cpu=x86-64" cargo test --quiet
echo "== demo + independent LAS check (laspy)"
scripts/check_las.sh
echo "== the Python package: wheel (maturin) and its tests (pytest)"
scripts/check_python.sh
echo "== the scalar kernels write the same bytes as the AVX2 kernels"
scripts/check_portable.sh
echo "== memory stays flat in flight length; 100 M pulses in 1 GiB"
python3 scripts/check_memory.py target/release/lidarsim
echo "== all checks passed"
