#!/usr/bin/env bash
# The Python package (crates/lidarsim-py): lint and document its Rust half,
# build the wheel with maturin, install it into target/pyenv and run its
# pytest tests against the command line's binary (built by check_las.sh).
# Needs only the Rust toolchain and python3; maturin, pytest, NumPy and laspy
# come from PyPI into the virtual environment.
set -euo pipefail
cd "$(dirname "$0")/.."

venv=target/pyenv
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
  "maturin>=1.9.4,<2" "pytest>=7" "numpy>=1.21" "laspy>=2.5" "lazrs>=0.6" "rasterio>=1.3" "distributed>=2023.1" "matplotlib>=3.5"

cargo clippy -p lidarsim-py --all-targets --quiet -- -D warnings
RUSTDOCFLAGS="-D warnings" cargo doc -p lidarsim-py --no-deps --quiet

rm -rf target/wheels
"$venv/bin/maturin" build --release --locked --quiet \
  -m crates/lidarsim-py/Cargo.toml --out target/wheels
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
  --force-reinstall --no-deps target/wheels/lidarsim-*.whl

[ -x target/release/lidarsim ] || cargo build --release --quiet
LIDARSIM_BIN="$PWD/target/release/lidarsim" \
  "$venv/bin/python" -m pytest -q -p no:cacheprovider crates/lidarsim-py/tests
