#!/usr/bin/env bash
# run_time_accuracy.sh: time to accuracy. For each case of MANIFEST, one run per variant
# (`pcp_reconstruct INPUT -o OUT/CASE/VARIANT.ply ARGS`) and Open3D's screened Poisson at depths 8,
# 9, 10 (pcp_poisson_open3d: PCA normals, tangent-plane orientation, density trim), one after the
# other in the same run; each mesh's wall time, and where the case has a ground-truth mesh its
# L2-CD x 100 (p2s) and NC (shapenet); cases without one (the gargoyle) are scored the same way
# against their input points and normals (how closely the mesh follows the data). The SGEMM rate of this machine is measured first
# (bench_nn --quick, when built). Prints a markdown table and writes OUT/results.tsv.
#
# Usage: bench/run_time_accuracy.sh OUT [CASE...]  (default cases: abc_00010074 bunny gargoyle)
# Environment: BIN (default <repo>/build/bin), MANIFEST (default <repo>/../shared/data/MANIFEST.tsv),
# VARIANTS (newline-separated "NAME:ARGS"; default, all in fp32: fast; default with its cosine
# schedule over 800, 1200, 1800, 2400 (the preset's) and 3600 steps).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/.." && pwd)
# shellcheck source=bench/lib_bench.sh
source "$here/lib_bench.sh"
bench_kept_networks_setup
[ $# -ge 1 ] || { sed -n 2,13p "$0"; exit 2; }
out=$1
shift
cases=("$@")
[ ${#cases[@]} -gt 0 ] || cases=(abc_00010074 bunny gargoyle)
default_variants="fast:--preset fast --precision fp32
default-800:--preset default --steps 800 --precision fp32
default-1200:--preset default --steps 1200 --precision fp32
default-1800:--preset default --steps 1800 --precision fp32
default:--preset default --precision fp32
default-3600:--preset default --steps 3600 --precision fp32"
variants=${VARIANTS:-$default_variants}
mkdir -p "$out"
wall() { awk '/^WALL /{print $2}' "$1"; }
# score MESH CASE: "L2 / NC" against the GT mesh, or against the input points and their normals
# (pcp_eval --gt-points) for a case without one
score() {
    local gt input l2 nc
    gt=$(bench_case_file "$2" 4)
    if [ -f "$gt" ]; then
        bench_score "$BIN/pcp_eval" "$1" "$gt"
    else
        input=$(bench_case_file "$2" 3)
        l2=$("$BIN/pcp_eval" "$1" "$input" --gt-points --protocol p2s --tsv | awk '$1=="chamfer_l2_x100"{print $2}')
        nc=$("$BIN/pcp_eval" "$1" "$input" --gt-points --protocol shapenet --tsv | awk '$1=="normal_consistency"{print $2}')
        printf "%.4f / %.3f (vs the input)" "$l2" "$nc"
    fi
}

sgemm="not measured (bench_nn not built)"
if [ -x "$BIN/bench_nn" ]; then
    sgemm=$("$BIN/bench_nn" --quick 2>/dev/null |
        awk -F'|' '$2 + 0 == 2 && $3 + 0 == 2000 && !done { printf "nn::gemm eigen%s, OpenBLAS%s GFLOP/s (512 x 512 x 2000, 2 threads)", $4, $5; done = 1 }')
fi
printf "case\tvariant\tseconds\tscore\n" >"$out/results.tsv"
for c in "${cases[@]}"; do
    input=$(bench_case_file "$c" 3)
    [ -f "$input" ] || { echo "run_time_accuracy: no input for case $c" >&2; exit 2; }
    mkdir -p "$out/$c"
    while IFS= read -r v; do
        [ -n "$v" ] || continue
        name=${v%%:*}
        args=${v#*:}
        # shellcheck disable=SC2086
        if /usr/bin/time -f "WALL %e" "$BIN/pcp_reconstruct" "$input" -o "$out/$c/$name.ply" $args >"$out/$c/$name.log" 2>&1; then
            printf "%s\t%s\t%s\t%s\n" "$c" "$name" "$(wall "$out/$c/$name.log")" "$(score "$out/$c/$name.ply" "$c")" >>"$out/results.tsv"
        else
            printf "%s\t%s\t-\tfailed (see %s)\n" "$c" "$name" "$out/$c/$name.log" >>"$out/results.tsv"
        fi
    done <<<"$variants"
    if [ -x "$BIN/pcp_poisson_open3d" ]; then
        for depth in 8 9 10; do
            if /usr/bin/time -f "WALL %e" "$BIN/pcp_poisson_open3d" "$input" "$out/$c/o3d_d$depth.ply" "$depth" >"$out/$c/o3d_d$depth.log" 2>&1; then
                printf "%s\t%s\t%s\t%s\n" "$c" "o3d_d$depth" "$(wall "$out/$c/o3d_d$depth.log")" "$(score "$out/$c/o3d_d$depth.ply" "$c")" >>"$out/results.tsv"
            fi
        done
    fi
done
bin_dir=$BIN manifest=$MANIFEST out_dir=$out machine_lines
echo "- SGEMM (bench_nn --quick, measured at the start of this run): $sgemm"
echo
echo "| case | variant | wall time (s) | L2-CD x 100 / NC (or data distance) |"
echo "| --- | --- | --- | --- |"
tail -n +2 "$out/results.tsv" | awk -F'\t' '{ printf "| %s | %s | %s | %s |\n", $1, $2, $3, $4 }'
