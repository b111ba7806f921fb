#!/usr/bin/env bash
# run_many.sh: several clouds in one fit (pcp_reconstruct INPUT... --output-dir, one-hot codes)
# against fitting each cloud alone, on cases of MANIFEST with a ground-truth mesh. Each case is
# first reconstructed alone (`pcp_reconstruct INPUT -o OUT/alone/CASE.ply --preset PRESET`), then
# all of them together (`pcp_reconstruct INPUTS... --output-dir OUT/together --preset PRESET
# [TOGETHER_ARGS]`), one after the other; every mesh is scored by pcp_eval (L2-CD x 100 with the p2s
# protocol, NC with shapenet). Prints a markdown table: per case the two scores and the wall time
# per cloud (alone: its run; together: the run's total / the number of clouds), and the machine.
#
# Usage: bench/run_many.sh OUT [CASE...]
#   default cases: abc_00010039 abc_00010074 abc_00016513 bunny fandisk
# Environment: BIN (default <repo>/build/bin), MANIFEST (default <repo>/../shared/data/MANIFEST.tsv),
# PRESET (default: default), TOGETHER_ARGS (extra pcp_reconstruct arguments of the joint run, e.g.
# "--steps 6000"), SKIP_ALONE=1 (reuse OUT/alone from an earlier run).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/.." && pwd)
# shellcheck source=bench/lib_bench.sh
source "$here/lib_bench.sh"
bench_kept_networks_setup
[ $# -ge 1 ] || { sed -n 2,15p "$0"; exit 2; }
out=$1
shift
cases=("$@")
[ ${#cases[@]} -gt 0 ] || cases=(abc_00010039 abc_00010074 abc_00016513 bunny fandisk)
mkdir -p "$out/alone" "$out/together"
score() { bench_score "$BIN/pcp_eval" "$1" "$2"; }
wall() { awk '/^WALL /{print $2}' "$1"; }

inputs=()
for c in "${cases[@]}"; do
    input=$(bench_case_file "$c" 3)
    [ -f "$input" ] || { echo "run_many: no input for case $c" >&2; exit 2; }
    inputs+=("$input")
    if [ "${SKIP_ALONE:-0}" != 1 ]; then
        /usr/bin/time -f "WALL %e" "$BIN/pcp_reconstruct" "$input" -o "$out/alone/$c.ply" --preset "$PRESET" \
            >"$out/alone/$c.log" 2>&1 || { echo "run_many: $c alone failed (see $out/alone/$c.log)" >&2; exit 1; }
    fi
done
# shellcheck disable=SC2086
/usr/bin/time -f "WALL %e" "$BIN/pcp_reconstruct" "${inputs[@]}" --output-dir "$out/together" --preset "$PRESET" \
    ${TOGETHER_ARGS:-} >"$out/together/run.log" 2>&1 || { echo "run_many: the joint run failed (see $out/together/run.log)" >&2; exit 1; }

n=${#cases[@]}
together_s=$(wall "$out/together/run.log")
bin_dir=$BIN manifest=$MANIFEST out_dir=$out machine_lines
echo "- Preset $PRESET; the joint run: ${TOGETHER_ARGS:-the preset steps}, $n clouds, $together_s s in all"
echo
echo "| case | alone: L2-CD x 100 / NC | alone (s) | together: L2-CD x 100 / NC | together (s per cloud) |"
echo "| --- | --- | --- | --- | --- |"
for c in "${cases[@]}"; do
    gt=$(bench_case_file "$c" 4)
    # The joint run names its outputs <directory>_<stem>.ply (inputs share the stem "input").
    input=$(bench_case_file "$c" 3)
    stem=$(basename "${input%.*}")
    joint=$out/together/$(basename "$(dirname "$input")")_$stem.ply
    [ -f "$joint" ] || joint=$out/together/$stem.ply
    printf "| %s | %s | %.1f | %s | %.1f |\n" "$c" "$(score "$out/alone/$c.ply" "$gt")" "$(wall "$out/alone/$c.log")" \
        "$(score "$joint" "$gt")" "$(echo "$together_s / $n" | bc -l)"
done
