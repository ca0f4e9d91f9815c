#!/usr/bin/env bash
# Instruction counts per pulse of the benchmark scenes under callgrind
# (stable on a shared machine, unlike wall-clock rates): only the work
# inside the simulation of pulse blocks is counted, not scene loading.
# Usage: [BIN=path/to/lidarsim] [SCENES="flat terrain"] scripts/profile_bench.sh [PULSES]
# (default 20000); needs valgrind.
set -euo pipefail
cd "$(dirname "$0")/.."
pulses=${1:-20000}
bin=${BIN:-target/release/lidarsim}
[ -n "${BIN:-}" ] || [ -x "$bin" ] || cargo build --release -q
for scene in ${SCENES:-flat terrain}; do
    out=$(mktemp)
    valgrind --tool=callgrind --callgrind-out-file="$out" \
        --toggle-collect='*simulate_block*' \
        "$bin" bench --scene "$scene" --threads 1 --pulses "$pulses" >/dev/null 2>&1
    total=$(callgrind_annotate "$out" 2>/dev/null | awk '/PROGRAM TOTALS/ {gsub(",","",$1); print $1}')
    echo "$scene instructions_per_pulse $((total / pulses))"
    rm -f "$out"
done
