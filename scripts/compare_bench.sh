#!/usr/bin/env bash
# Compares the speed of two lidarsim builds on a shared, noisy machine by
# alternating them: each round runs `lidarsim bench` once with each binary
# (which one goes first alternates), so that both see the same load. Prints
# every run, the per-round ratio NEW/OLD per thread count, the range of each
# binary, the median ratio, and how many runs reach TARGET pulses/s. Also
# checks that both builds write the same LAS (the benchmark's hash), since an
# optimisation must not change the output. Not part of the test suite.
#
# Usage: [TARGET=1000000] scripts/compare_bench.sh OLD_BIN NEW_BIN [ROUNDS] [SCENE]
# (default 4 rounds of the terrain scene on 1 and 2 threads).
set -euo pipefail
if [ $# -lt 2 ]; then
    echo "usage: $0 OLD_BIN NEW_BIN [ROUNDS] [SCENE]" >&2
    exit 2
fi
old=$1
new=$2
rounds=${3:-4}
scene=${4:-terrain}
target=${TARGET:-1000000}
for bin in "$old" "$new"; do
    [ -x "$bin" ] || { echo "$0: $bin is not an executable" >&2; exit 2; }
done
log=$(mktemp)
trap 'rm -f "$log"' EXIT

# One run: "<label> <round> <threads> <pulses_per_s> <hash>" per thread count.
run() {
    local label=$1 bin=$2 round=$3
    "$bin" bench --scene "$scene" --threads 1,2 2>&1 | awk -v l="$label" -v r="$round" '
        $2 == "threads" && $4 == "pulses_per_s" { rate[$3] = $5 }
        $2 == "threads" && $4 == "las_fnv1a" { hash[$3] = $5 }
        END { for (t in rate) print l, r, t, rate[t], hash[t] }'
}

for r in $(seq "$rounds"); do
    if [ $((r % 2)) -eq 1 ]; then
        run old "$old" "$r" >>"$log"
        run new "$new" "$r" >>"$log"
    else
        run new "$new" "$r" >>"$log"
        run old "$old" "$r" >>"$log"
    fi
    awk -v r="$r" '$2 == r { v[$1 "," $3] = $4 }
        END { printf "round %d:", r
              for (t = 1; t <= 2; t++)
                  if (v["old," t] > 0)
                      printf "  %d thread(s) old %d new %d ratio %.3f", t, v["old," t], v["new," t], v["new," t] / v["old," t]
              print "" }' "$log"
done

awk -v target="$target" '
    { rate[$1 "," $2 "," $3] = $4; hashes[$5] = 1; seen[$3] = 1 }
    END {
        for (t = 1; t <= 2; t++) {
            if (!(t in seen)) continue
            n = 0; reached["old"] = 0; reached["new"] = 0
            for (who in reached) { lo[who] = -1; hi[who] = 0 }
            for (k in rate) {
                split(k, f, ",")
                if (f[3] != t) continue
                v = rate[k]; who = f[1]
                if (lo[who] < 0 || v < lo[who]) lo[who] = v
                if (v > hi[who]) hi[who] = v
                if (v >= target) reached[who]++
                if (who == "new" && (("old," f[2] "," t) in rate)) ratios[++n] = v / rate["old," f[2] "," t]
            }
            # Median of the per-round ratios (insertion sort: few rounds).
            for (i = 2; i <= n; i++) { x = ratios[i]; j = i - 1
                while (j > 0 && ratios[j] > x) { ratios[j + 1] = ratios[j]; j-- }
                ratios[j + 1] = x }
            med = n % 2 ? ratios[(n + 1) / 2] : (ratios[n / 2] + ratios[n / 2 + 1]) / 2
            printf "%d thread(s): old %d-%d, new %d-%d pulses/s; median ratio new/old %.3f over %d rounds; runs at or above %d: old %d, new %d\n",
                t, lo["old"], hi["old"], lo["new"], hi["new"], med, n, target, reached["old"], reached["new"]
            delete ratios
        }
        distinct = 0
        for (h in hashes) distinct++
        if (distinct != 1) { print "LAS hashes differ between the builds (or runs)"; exit 1 }
        print "LAS hashes: the same for both builds"
    }' "$log"
