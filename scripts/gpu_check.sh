#!/usr/bin/env bash
# Run on a bare GPU machine (DESIGN.md §3): an NVIDIA GPU, the CUDA toolkit, CMake, ninja and a C++
# compiler, but none of the project's Debian libraries, no package manager, no network. Unpacks
# the packages that scripts/gpu_bundle.sh put in .gpu/ into a prefix under /tmp, builds the lean
# configuration (-DRETIMEGS_GPU_ONLY=ON) on every core, runs the `gpu` tests and the GPU
# benchmarks, and prints a short table last. Logs (build.log, ctest.log, benchmarks.log,
# summary.txt) go to $OUT when it is set, else to build-gpu/logs/. Exit status 0: all passed.
#
#   bash scripts/gpu_check.sh [--no-gpu-ok] [CMAKE_ARGS...]
#
# --no-gpu-ok carries on without a GPU, to check the script on a build machine: the tests then
# skip with the reason, and the benchmarks are not run. CMAKE_ARGS go to the configure step, e.g.
# -DCMAKE_CUDA_ARCHITECTURES=90. RETIMEGS_GPU_TESTS (a ctest -R regex) runs some of the gpu tests
# only. RETIMEGS_GPU_TEST_TIMEOUT (seconds, default 300) bounds the
# tests, RETIMEGS_GPU_BENCH_TIMEOUT (default 240) each benchmark. With RETIMEGS_GPU_SANITIZE=1,
# each failing test runs once more under compute-sanitizer (sanitizer.log), for the access that
# went wrong.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
no_gpu_ok=0
if [[ ${1:-} == --no-gpu-ok ]]; then
  no_gpu_ok=1
  shift
fi
source "$root/scripts/gpu_common.sh"
logs="${OUT:-$build/logs}"
test_timeout="${RETIMEGS_GPU_TEST_TIMEOUT:-300}"
bench_timeout="${RETIMEGS_GPU_BENCH_TIMEOUT:-240}"

gpu_check_machine
gpu_unpack_bundle
mkdir -p "$logs"
# The GPU tests and benchmarks alone, whether or not gpu_panoptic.sh built the app here before.
gpu_build "$logs/build.log" all -DRETIMEGS_GPU_APP=OFF "$@"

ctest_log="$logs/ctest.log"
tests_ok=1
timeout "$test_timeout" ctest --test-dir "$build" -L gpu ${RETIMEGS_GPU_TESTS:+-R "$RETIMEGS_GPU_TESTS"} \
  --output-on-failure -j "$(nproc)" \
  > "$ctest_log" 2>&1 || tests_ok=0
# "100% tests passed, 0 tests failed out of N", or from CMake 4 "100% tests passed out of N".
total=$(sed -n 's/^[0-9]*% tests passed.* out of \([0-9]*\)$/\1/p' "$ctest_log")
passed=$(grep -cE '^ *[0-9]+/[0-9]+ Test +#[0-9]+: .* Passed' "$ctest_log" || true)
skipped=$(grep -cE '^ *[0-9]+/[0-9]+ Test +#[0-9]+: .*\*\*\*Skipped' "$ctest_log" || true)
if [[ -z $total || $total -eq 0 ]]; then
  tests_ok=0
  tests="none found (log: $ctest_log)"
else
  tests="$passed passed, $((total - passed - skipped)) failed, $skipped skipped (of $total)"
  if ((skipped)); then  # the reason a test gave for skipping (tests/cuda/require_gpu.hpp)
    reason=$(grep -m 1 -h '^no usable CUDA device' "$build/Testing/Temporary/LastTest.log" || true)
    tests+="${reason:+: $reason}"
  fi
fi

# A failing test once more under compute-sanitizer: ctest names it "Suite.Test", and the
# executable that holds it is the one whose test list names it.
if ((!tests_ok && gpu)) && [[ ${RETIMEGS_GPU_SANITIZE:-0} == 1 ]] &&
  command -v compute-sanitizer > /dev/null; then
  sanitizer_log="$logs/sanitizer.log"
  : > "$sanitizer_log"
  sed -n 's/^[[:space:]]*[0-9]* - \([A-Za-z0-9_/]*\.[A-Za-z0-9_/]*\) (.*$/\1/p' "$ctest_log" |
    while read -r failed; do
      for exe in "$build"/tests/test_*; do
        "$exe" --gtest_list_tests 2> /dev/null | grep -qE "^  ${failed#*.}( |$)" || continue
        echo "== $failed in $(basename "$exe")" >> "$sanitizer_log"
        timeout 120 compute-sanitizer --tool memcheck "$exe" --gtest_filter="$failed" \
          >> "$sanitizer_log" 2>&1 || true
        break
      done
    done
fi

# The GPU benchmarks that bench/CMakeLists.txt registered, one executable a line.
bench_log="$logs/benchmarks.log"
: > "$bench_log"
bench_rows=()
bench_ok=1
while read -r exe; do
  [[ -n $exe ]] || continue
  name=$(basename "$exe")
  if ((!gpu)); then
    bench_rows+=("$name: not run (no GPU)")
    continue
  fi
  output=$(mktemp)
  started=$SECONDS
  status=0
  timeout "$bench_timeout" "$exe" > "$output" 2>&1 || status=$?
  { echo "== $name (exit status $status, $((SECONDS - started)) s)"; cat "$output"; } >> "$bench_log"
  if ((status == 124)); then
    bench_ok=0
    bench_rows+=("$name: FAILED, stopped after ${bench_timeout} s (log: $bench_log)")
  elif ((status)); then
    bench_ok=0
    bench_rows+=("$name: FAILED, exit status $status (log: $bench_log)")
  else
    bench_rows+=("$name ($((SECONDS - started)) s):")
  fi
  # Its figures marked "headline: ...", else its last line; those printed before a failure too.
  headlines=$(sed -n 's/^headline: //p' "$output")
  [[ -n $headlines ]] || headlines=$(tail -n 1 "$output")
  while IFS= read -r line; do bench_rows+=("    $line"); done <<< "$headlines"
  rm -f "$output"
done < "$build/gpu_benchmarks.txt"
((${#bench_rows[@]})) || bench_rows+=("none registered (bench/cuda_*.cu)")

{
  echo "gpu_check summary"
  echo "  card        $card"
  echo "  nvcc        $("$nvcc" --version | sed -n 's/.*release \([0-9.]*\).*/\1/p'), $(cmake --version | head -n 1)"
  echo "  build       -DRETIMEGS_GPU_ONLY=ON, $build_seconds s on $(nproc) cores"
  echo "  gpu tests   $tests"
  echo "  benchmarks"
  for row in "${bench_rows[@]}"; do echo "    $row"; done
} | tee "$logs/summary.txt"
((tests_ok && bench_ok))
