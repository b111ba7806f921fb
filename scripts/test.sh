#!/usr/bin/env bash
# The README's test command: installs dependencies, builds Release with warnings as errors, runs
# every CTest label (unit, e2e, realdata, install-consumer), runs the readers' libFuzzer targets
# for a short smoke (clang, build-fuzz/), then builds again with
# AddressSanitizer + UndefinedBehaviorSanitizer (its arithmetic checks: CMakeLists.txt) and runs the unit tests under them (without the
# [heavy] and [cli] cases). After each
# CTest run it prints which GEMM back ends and precisions that build ran (test cases of an absent
# one are reported Skipped by CTest).
# Build directories: build-test/, build-fuzz/ and build-asan/ (override with PCP_BUILD_ROOT).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
root=${PCP_BUILD_ROOT:-$here}
jobs=${PCP_JOBS:-$(nproc)}

# Seconds per stage, printed at the end (and on failure) so the CI budget can be followed.
stage_names=()
stage_secs=()
stage_start=$(date +%s)
stage_done() {
  local now
  now=$(date +%s)
  stage_names+=("$1")
  stage_secs+=($((now - stage_start)))
  stage_start=$now
}
print_stages() {
  local i total=0
  for i in "${!stage_names[@]}"; do
    printf 'test.sh: %-28s %5d s\n' "${stage_names[$i]}" "${stage_secs[$i]}"
    total=$((total + stage_secs[i]))
  done
  printf 'test.sh: %-28s %5d s\n' "total" "$total"
}
trap print_stages EXIT

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
stage_done "dependencies"

# Benchmarks are not compiled here (they are not tests; CGAL's Poisson alone costs minutes of
# the CI budget): build them with the plain Release build of the README.
cmake -S "$here" -B "$root/build-test" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPCP_WERROR=ON -DPCP_BUILD_BENCH=OFF
cmake --build "$root/build-test" -j "$jobs"
stage_done "Release build"
run_ctest "$root/build-test" --output-on-failure -j "$jobs"
stage_done "Release tests"

# The readers' libFuzzer targets (tests/fuzz/), each run for PCP_FUZZ_SECONDS (default 5 here, 30 in CMake) from
# its seed corpus, where clang is installed (install-deps.sh installs it). Long campaigns:
# scripts/fuzz.sh.
if command -v clang++-14 >/dev/null; then
  cmake -S "$here" -B "$root/build-fuzz" -G Ninja -DCMAKE_CXX_COMPILER=clang++-14 -DCMAKE_BUILD_TYPE=Debug \
        -DCMAKE_CXX_FLAGS_DEBUG=-O0 -DPCP_FUZZ=ON -DPCP_FUZZ_SECONDS="${PCP_FUZZ_SECONDS:-5}" \
        -DPCP_BUILD_APPS=OFF -DPCP_BUILD_TESTS=OFF -DPCP_BUILD_BENCH=OFF -DPCP_BUILD_PYTHON=OFF
  cmake --build "$root/build-fuzz" -j "$jobs"
  stage_done "fuzz build"
  ctest --test-dir "$root/build-fuzz" --output-on-failure -j "$jobs" -L fuzz
  stage_done "fuzz smoke"
else
  echo "test.sh: the fuzz smoke tests did not run: clang++-14 is not installed (scripts/install-deps.sh installs it)"
fi

cmake -S "$here" -B "$root/build-asan" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG=-O1 -DPCP_WERROR=ON \
      -DPCP_SANITIZE=ON -DPCP_BUILD_BENCH=OFF
# Only what the unit tests run there (their binary; its [cli] cases, which run the apps, are left
# out under the sanitizers: tests/CMakeLists.txt).
cmake --build "$root/build-asan" -j "$jobs" --target pcp_unit_tests
stage_done "sanitizer build"
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  run_ctest "$root/build-asan" --output-on-failure -j "$jobs" -L unit
stage_done "sanitizer tests"
