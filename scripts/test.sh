#!/usr/bin/env bash
# The README's test command: installs dependencies, builds Release with warnings as errors, runs
# every CTest label (unit, e2e, realdata, install-consumer), then builds again with
# AddressSanitizer + UndefinedBehaviorSanitizer and runs the unit tests under them. After each
# CTest run it prints which GEMM back ends and precisions that build ran (test cases of an absent
# one are reported Skipped by CTest).
# Build directories: build-test/ and build-asan/ (override with PCP_BUILD_ROOT).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
root=${PCP_BUILD_ROOT:-$here}
jobs=${PCP_JOBS:-$(nproc)}

# ctest in build directory $1 (further arguments passed on), then the back-end line of that build;
# returns ctest's status.
run_ctest() {
  local dir=$1 status=0
  shift
  ctest --test-dir "$dir" "$@" || status=$?
  "$dir/tests/pcp_unit_tests" --pcp-report-backends || true
  return "$status"
}
bash "$here/scripts/install-deps.sh"

# Benchmarks are not compiled here (they are not tests; CGAL's Poisson alone costs minutes of
# the CI budget): build them with the plain Release build of the README.
cmake -S "$here" -B "$root/build-test" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPCP_WERROR=ON -DPCP_BUILD_BENCH=OFF
cmake --build "$root/build-test" -j "$jobs"
run_ctest "$root/build-test" --output-on-failure -j "$jobs"

cmake -S "$here" -B "$root/build-asan" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG=-O1 -DPCP_WERROR=ON \
      -DPCP_SANITIZE=ON -DPCP_BUILD_BENCH=OFF
cmake --build "$root/build-asan" -j "$jobs"
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  run_ctest "$root/build-asan" --output-on-failure -j "$jobs" -L unit
