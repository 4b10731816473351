#!/usr/bin/env bash
# Fuzzing and sanitizer checks of every parser (fuzz/; docs/cli.md "Fuzzing").
#
#   scripts/fuzz.sh [SECONDS] [TARGET...]   builds build-fuzz/ (clang, libFuzzer + ASan + UBSan)
#       and fuzzes each target (all by default) for SECONDS (600), one after the other, from its
#       seed corpus fuzz/corpus/<target>/; new inputs go to build-fuzz/fuzz/work/<target>/, crash
#       inputs to build-fuzz/fuzz/work/artifacts/. Ends with exec/s and coverage per target.
#   scripts/fuzz.sh --check                  builds build-fuzz/ and runs its ctest: the parsers'
#       unit tests under ASan + UBSan, every seed corpus replayed, every target fuzzed for
#       RETIMEGS_FUZZ_SECONDS (10). Part of scripts/test.sh; ends with ctest's summary line.
#   scripts/fuzz.sh --run TARGET SECONDS BINARY WORKDIR   one bounded run (used by that ctest).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build="$root/build-fuzz"
# -rss_limit_mb: a parser that allocates gigabytes for a small file is a finding; -timeout: so is
# one that takes more than 10 s on one input.
flags=(-rss_limit_mb=2048 -timeout=10 -print_final_stats=1)

targets() {
  sed -n 's/^retimegs_fuzzer(\([a-z_]*\) .*/\1/p' "$root/fuzz/CMakeLists.txt"
}

configure_and_build() {
  local launcher=()
  if command -v ccache > /dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
  cmake -S "$root" -B "$build" -G Ninja -DCMAKE_CXX_COMPILER=clang++ \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DRETIMEGS_FUZZ=ON -DRETIMEGS_NATIVE=OFF \
    "${launcher[@]}" "$@" > /dev/null
  cmake --build "$build" -j "$(nproc)"
}

# run TARGET SECONDS BINARY WORKDIR: fuzz one target; prints libFuzzer's last status line.
run() {
  local target=$1 seconds=$2 binary=$3 work=$4
  mkdir -p "$work/$target" "$work/artifacts"
  local log="$work/$target.log"
  local status=0
  "$binary" "${flags[@]}" -max_total_time="$seconds" \
    -artifact_prefix="$work/artifacts/$target-" "$work/$target" "$root/fuzz/corpus/$target" \
    > "$log" 2>&1 || status=$?
  # libFuzzer's last "#N<tab>DONE cov: C ft: F ..." line and its final statistics.
  local last
  last=$(grep -E '^#[0-9]+[[:space:]].*cov: ' "$log" | tail -n 1 || true)
  final_stat() { sed -n "s/^stat::$1: *//p" "$log" | tail -n 1; }
  printf '%-16s cov %-6s ft %-6s exec/s %-7s runs %s\n' "$target" \
    "$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<< "$last")" \
    "$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<< "$last")" \
    "$(final_stat average_exec_per_sec)" "$(final_stat number_of_executed_units)"
  if ((status != 0)); then
    echo "fuzz: $target FAILED (status $status); log $log, inputs:" >&2
    ls "$work/artifacts/$target-"* >&2 2> /dev/null || true
    grep -E 'ERROR|SUMMARY|runtime error|terminate' "$log" | head -n 5 >&2 || true
  fi
  return "$status"
}

case "${1:-}" in
  --run)
    shift
    run "$@"
    ;;
  --check)
    configure_and_build
    cd "$build"
    ctest --output-on-failure -j "$(nproc)"
    ;;
  *)
    seconds=${1:-600}
    shift || true
    configure_and_build
    selected=("$@")
    if ((${#selected[@]} == 0)); then mapfile -t selected < <(targets); fi
    failed=0
    summary=()
    for t in "${selected[@]}"; do
      line=$(run "$t" "$seconds" "$build/fuzz/${t}_fuzz" "$build/fuzz/work") || failed=1
      echo "$line"
      summary+=("$line")
    done
    echo "fuzz: ${#selected[@]} targets, $seconds s each:"
    printf '  %s\n' "${summary[@]}"
    exit "$failed"
    ;;
esac
