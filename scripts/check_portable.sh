#!/usr/bin/env bash
# The scalar kernels write what the AVX2 kernels write: the demo flown by
# the x86-64-v3 release build and by the baseline x86-64 release build
# (target/portable, built by scripts/test.sh) must give the same
# files, byte for byte. SOURCE_DATE_EPOCH fixes the LAS creation date.
set -euo pipefail
cd "$(dirname "$0")/.."
portable=target/portable/release/lidarsim
[ -x "$portable" ] || { echo "no $portable: run scripts/test.sh, which builds it" >&2; exit 1; }
rm -rf target/demo-v3 target/demo-portable
SOURCE_DATE_EPOCH=1790000000 target/release/lidarsim demo -o target/demo-v3 > /dev/null 2>&1
SOURCE_DATE_EPOCH=1790000000 "$portable" demo -o target/demo-portable > /dev/null 2>&1
for f in points.las points.xyz trajectory.csv trajectory_observed.csv survey.toml; do
    cmp "target/demo-v3/$f" "target/demo-portable/$f"
done
echo "the portable build's demo files equal the x86-64-v3 build's"
