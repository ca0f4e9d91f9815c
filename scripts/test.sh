#!/usr/bin/env bash
# The whole test suite, as CI runs it (.ci/run calls this script).
# Needs only the Rust toolchain and python3; the Python packages of the
# independent LAS check and of the lidarsim package's tests are installed
# into target/pyenv by check_las.sh and check_python.sh, and Chromium (for
# the report's browser check) from Debian's packages by install_chromium.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
# One build of everything, not kept for edits: no incremental state
# (gigabytes of it, and time to write).
export CARGO_INCREMENTAL=0
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
step "portable build (-C target-cpu=x86-64): the binary of the scalar kernels"
# The scalar twins of the SIMD kernels are what this build runs. They are
# compiled into every build, and the kernels' tests above check the AVX2
# forms against them and against their definitions; here the demo's bytes
# of the build that runs them are checked against the x86-64-v3 build's
# (check_portable.sh, below). The rest of the suite does not depend on the
# processor's instructions.
# The binary with the test profile's optimisation (opt-level 2, parallel
# code generation): minutes less to build than a release build.
CARGO_TARGET_DIR=target/portable RUSTFLAGS="-C target-cpu=x86-64" \
  cargo build --quiet --profile test -p lidarsim-cli
step "demo + independent LAS check (laspy)"
scripts/check_las.sh
step "README.md's demo figures match the demo's summary and files"
python3 scripts/readme_figures.py target/demo-check --check
step "docs/img pictures by scripts/make_images.sh; the report in headless Chromium, no blank panel"
scripts/make_images.sh target/images-check
step "the Python package: wheel (maturin) and its tests (pytest)"
scripts/check_python.sh
step "the scalar kernels write the same bytes as the AVX2 kernels"
scripts/check_portable.sh
step "memory stays flat in flight length; 100 M pulses in 1 GiB"
python3 scripts/check_memory.py target/release/lidarsim
step "all checks passed"
