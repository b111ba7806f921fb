#!/usr/bin/env bash
# The README's test command: installs dependencies, builds Release with warnings as errors, runs
# every CTest label (unit, e2e, realdata, install-consumer), then builds again with
# AddressSanitizer + UndefinedBehaviorSanitizer and runs the unit tests under them.
# Build directories: build-test/ and build-asan/ (override with PCP_BUILD_ROOT).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
root=${PCP_BUILD_ROOT:-$here}
jobs=${PCP_JOBS:-$(nproc)}
bash "$here/scripts/install-deps.sh"

# Benchmarks are not compiled here (they are not tests; CGAL's Poisson alone costs minutes of
# the CI budget): build them with the plain Release build of the README.
cmake -S "$here" -B "$root/build-test" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPCP_WERROR=ON -DPCP_BUILD_BENCH=OFF
cmake --build "$root/build-test" -j "$jobs"
ctest --test-dir "$root/build-test" --output-on-failure -j "$jobs"

cmake -S "$here" -B "$root/build-asan" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG=-O1 -DPCP_WERROR=ON \
      -DPCP_SANITIZE=ON -DPCP_BUILD_BENCH=OFF
cmake --build "$root/build-asan" -j "$jobs"
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir "$root/build-asan" --output-on-failure -j "$jobs" -L unit
