#!/usr/bin/env bash
# Interleaved A/B timing of render_bench binaries on a shared, noisy machine: each round runs
# every binary once, and the figure kept per benchmark and binary is the minimum wall time over
# all rounds (the run least disturbed by other jobs). REPETITIONS (default 4) and MIN_TIME
# (seconds per repetition, default Google Benchmark's) set each run's length: REPETITIONS=8
# MIN_TIME=0.05 takes minima of near-single iterations, the most robust on a busy host.
# Reads the JSON output: Google Benchmark's CSV reporter aborts when one filter mixes
# benchmarks with different counters (BM_Stage and BM_Forward, say).
#
#   bash bench/render_ab.sh 'BM_ForwardBackward' 4 build/bench/render_bench /tmp/old/render_bench
set -euo pipefail
if [[ $# -lt 3 ]]; then
  echo "usage: $0 FILTER ROUNDS BINARY [BINARY...]" >&2
  exit 2
fi
filter=$1 rounds=$2
shift 2
for ((round = 0; round < rounds; ++round)); do
  for binary in "$@"; do
    "$binary" --benchmark_filter="$filter" --benchmark_repetitions="${REPETITIONS:-4}" \
      ${MIN_TIME:+--benchmark_min_time="$MIN_TIME"} --benchmark_format=json 2>/dev/null |
      awk -v binary="$binary" -F'"' '
        $2 == "run_name" { name = $4; sub(/\/process_time\/real_time/, "", name) }
        $2 == "run_type" { iteration = $4 == "iteration" }
        $2 == "real_time" && iteration { sub(/^: */, "", $3); sub(/,$/, "", $3); print binary, name, $3 + 0 }'
  done
done | awk '{ key = $2 " " $1; if (!(key in best) || $3 < best[key]) best[key] = $3 }
            END { for (key in best) printf "%-45s %8.2f ms\n", key, best[key] }' | sort
