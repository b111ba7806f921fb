#!/usr/bin/env bash
# Tests of bench/run_scaling.sh without real runs (CTest label unit, about a second). A fake
# pcp_reconstruct prints a summary line like the real one (its numbers derived from
# --builtin-points) and fails for one size. Checks: bad command lines exit 2 naming the problem;
# the table has one parsed row per size, the failed size's row says so, and the exit status is 1.
# Exit 77 (skipped) without /usr/bin/time. Usage: scaling_script_test.sh WORKDIR
set -uo pipefail
work=$1
script="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)/bench/run_scaling.sh"
# shellcheck source=tests/script_check.sh
source "$(dirname "${BASH_SOURCE[0]}")/script_check.sh"
[ -x /usr/bin/time ] || { echo "skipped: no /usr/bin/time"; exit 77; }
rm -rf "$work"
mkdir -p "$work/bin"
cat >"$work/bin/pcp_reconstruct" <<'FAKE'
#!/usr/bin/env bash
n=0
while [ $# -gt 0 ]; do
    case $1 in --builtin-points) n=$2; shift 2 ;; *) shift ;; esac
done
if [ "$n" = 20000 ]; then echo "pcp_reconstruct: error: out of luck" >&2; exit 1; fi
echo "wrote x.ply: 10 vertices, 16 faces, closed" >&2
echo "| read 0.1 s | denoise 0.5 s (1 passes) | prior 10 s (loss 0.1) | query net 40 s (3000 steps, loss 0.01) | SDF grid 5 s ($((n * 10)) evaluations) | marching cubes 0.25 s | total 60 s | precision bf16 (oneDNN) | peak memory 100 MiB" >&2
FAKE
chmod +x "$work/bin/pcp_reconstruct"

"$script" --points "10 x" --bin "$work/bin" >"$work/bad.out" 2>&1
check "a size that is not a number exits 2" test $? -eq 2
check "... naming it" contains "$work/bad.out" "--points: 'x' is not a number"
"$script" --frobnicate >"$work/bad2.out" 2>&1
check "an unknown option exits 2" test $? -eq 2
"$script" --bin "$work/nowhere" >"$work/bad3.out" 2>&1
check "a missing pcp_reconstruct exits 2" test $? -eq 2
check "... naming it" contains "$work/bad3.out" "$work/nowhere/pcp_reconstruct not found"

"$script" --points "10000 20000 40000" --bin "$work/bin" --out "$work/out" -- --steps 5 >"$work/table.md" 2>&1
check "a failed size makes the exit status 1" test $? -eq 1
check "the extra options are shown" contains "$work/table.md" "--builtin-points N --steps 5"
check "row of 10000 parsed" contains "$work/table.md" "| 10000 | 60.0 | 600.0 | 0.5 | 10.0 | 40.0 | 5.0 | 100000 | 20000 | 0.25 |"
check "row of 40000 parsed" contains "$work/table.md" "| 40000 | 60.0 | 150.0 | 0.5 | 10.0 | 40.0 | 5.0 | 400000 | 80000 | 0.25 |"
check "the failed size's row says so" contains "$work/table.md" "| 20000 | failed (see $work/out/scale_20000.log)"
exit "$failed"
