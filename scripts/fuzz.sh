#!/usr/bin/env bash
# Long fuzzing campaigns (issue 19): builds the libFuzzer targets with clang (build-fuzz/) and runs
# each for RUNS executions (default 10 million) from a copy of its seed corpus, one after another,
# then prints one Markdown row per target: executions, seconds, coverage (libFuzzer's cov / ft
# counters), corpus size and findings. Findings (crash-*, oom-*, timeout-*, leak-*) stay in OUT.
# Usage: scripts/fuzz.sh OUT [TARGET...]     (targets: ply text npy mesh_text netfile prior)
# Environment: RUNS (default 10000000), MAX_LEN (largest input in bytes, default 4096: the readers'
# branches are all reached by small files, and larger ones slow the executions tenfold),
# PCP_BUILD_ROOT (default: the repository).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
root=${PCP_BUILD_ROOT:-$here}
[ $# -ge 1 ] || { sed -n 2,7p "$0"; exit 2; }
out=$(mkdir -p "$1" && cd "$1" && pwd)
shift
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(ply text npy mesh_text netfile prior)
runs=${RUNS:-10000000}
cmake -S "$here" -B "$root/build-fuzz" -G Ninja -DCMAKE_CXX_COMPILER=clang++-14 -DCMAKE_BUILD_TYPE=Debug \
      -DCMAKE_CXX_FLAGS_DEBUG=-O0 -DPCP_FUZZ=ON -DPCP_BUILD_APPS=OFF -DPCP_BUILD_TESTS=OFF -DPCP_BUILD_BENCH=OFF \
      -DPCP_BUILD_PYTHON=OFF >"$out/cmake.log"
cmake --build "$root/build-fuzz" >>"$out/cmake.log"
echo "| target | executions | seconds | coverage (cov / ft) | corpus | findings |"
echo "| --- | --- | --- | --- | --- | --- |"
for t in "${targets[@]}"; do
    rm -rf "${out:?}/$t"
    mkdir -p "$out/$t/corpus"
    cp "$here/tests/fuzz/corpus/$t/"* "$out/$t/corpus/"
    start=$(date +%s)
    status=0
    (cd "$out/$t" && "$root/build-fuzz/fuzz/fuzz_$t" -runs="$runs" -max_len="${MAX_LEN:-4096}" -rss_limit_mb=2048 -timeout=10 \
        -print_final_stats=1 -artifact_prefix="$out/$t/" corpus >"$out/$t/fuzz.log" 2>&1) || status=$?
    secs=$(( $(date +%s) - start ))
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$out/$t/fuzz.log" | tail -1)
    cov=$(grep -oE 'cov: [0-9]+ ft: [0-9]+' "$out/$t/fuzz.log" | tail -1 | awk '{print $2 " / " $4}')
    findings=$(find "$out/$t" -maxdepth 1 -name 'crash-*' -o -maxdepth 1 -name 'oom-*' -o -maxdepth 1 -name 'timeout-*' -o -maxdepth 1 -name 'leak-*' | wc -l)
    echo "| $t | ${execs:-?} | $secs | $cov | $(ls "$out/$t/corpus" | wc -l) | $findings (exit $status) |"
done
