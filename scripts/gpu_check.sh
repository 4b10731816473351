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
build="$root/build-gpu"
prefix=/tmp/retimegs-gpu-deps
logs="${OUT:-$build/logs}"
test_timeout="${RETIMEGS_GPU_TEST_TIMEOUT:-300}"
bench_timeout="${RETIMEGS_GPU_BENCH_TIMEOUT:-240}"

die() {
  echo "gpu_check: $*" >&2
  exit 1
}

no_gpu_ok=0
if [[ ${1:-} == --no-gpu-ok ]]; then
  no_gpu_ok=1
  shift
fi

# What the machine must have; each missing piece ends the run here with one line.
gpu=0
card="none"
if listed=$(nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader \
  2> /dev/null) && [[ -n $listed ]]; then
  gpu=1
  card=$(head -n 1 <<< "$listed")
elif ((!no_gpu_ok)); then
  die "no NVIDIA GPU: nvidia-smi is missing or lists none"
fi
nvcc=$(command -v nvcc || true)
if [[ -z $nvcc && -x /usr/local/cuda/bin/nvcc ]]; then nvcc=/usr/local/cuda/bin/nvcc; fi
[[ -n $nvcc ]] || die "no nvcc: the CUDA toolkit is missing or its bin/ is not on PATH"
for tool in cmake ninja; do
  command -v "$tool" > /dev/null || die "no $tool on PATH"
done
command -v "${CXX:-c++}" > /dev/null || command -v g++ > /dev/null ||
  die "no C++ compiler (c++ or g++, or \$CXX) on PATH"
debs=("$root"/.gpu/*.deb)
[[ -e ${debs[0]} ]] ||
  die "no .gpu/*.deb: run scripts/gpu_bundle.sh on a build machine and bring .gpu/ along"

# The packages' files, under a prefix of our own: never into / (no package manager here).
rm -rf "$prefix"
mkdir -p "$prefix" "$logs"
for deb in "${debs[@]}"; do
  if command -v dpkg-deb > /dev/null; then
    dpkg-deb -x "$deb" "$prefix"
  else  # a .deb is an ar archive whose data.tar.* holds the files
    unpack=$(mktemp -d)
    (cd "$unpack" && ar x "$deb" && tar -xf data.tar.* -C "$prefix")
    rm -rf "$unpack"
  fi
done

started=$SECONDS
build_log="$logs/build.log"
# Debian puts CMake packages of architecture-specific libraries under lib/<multiarch>/cmake/,
# which CMake searches only where it knows the multiarch name: both places are given.
if ! cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DRETIMEGS_GPU_ONLY=ON \
  -DCMAKE_CUDA_COMPILER="$nvcc" \
  "-DCMAKE_PREFIX_PATH=$prefix/usr;$prefix/usr/lib/x86_64-linux-gnu/cmake" "$@" \
  > "$build_log" 2>&1; then
  tail -n 30 "$build_log"
  die "configuring failed (log: $build_log)"
fi
if ! cmake --build "$build" -j "$(nproc)" >> "$build_log" 2>&1; then
  tail -n 30 "$build_log"
  die "the build failed (log: $build_log)"
fi
build_seconds=$((SECONDS - started))

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
