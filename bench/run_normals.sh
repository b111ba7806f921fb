#!/usr/bin/env bash
# run_normals.sh: oriented normals of the input points (`pcp_reconstruct --normals`, issue 18) against
# Open3D's orientation (`pcp_orient_open3d`: PCA on 30 neighbours, orient_normals_consistent_tangent_plane(15)),
# both scored by `pcp_eval --normals` against the GT mesh: the fraction of points whose normal points
# to the GT's outside, and the mean angle to the nearest GT face's normal (oriented, and as a
# direction alone). PCP's normals come from the networks a benchmark run kept (a run_benchmarks.sh
# output made with `-- --keep-checkpoint`): `pcp_reconstruct INPUT --resume --keep-checkpoint --normals`
# re-meshes without fitting again. Prints one Markdown row per case with a GT mesh and kept networks.
#
# Usage: bench/run_normals.sh OUT
# Environment: BIN (default <repo>/build/bin), MANIFEST (default <repo>/../shared/data/MANIFEST.tsv),
# PRESET (default: default), FROM (--normals-from: mesh, pca or field; default mesh), CASES (space-separated; default every such case), LOCK (a file: run
# every command under `flock LOCK`).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/.." && pwd)
# shellcheck source=bench/lib_bench.sh
source "$here/lib_bench.sh"
bench_kept_networks_setup
[ $# -eq 1 ] || { sed -n 2,14p "$0"; exit 2; }
out=$1
locked() { if [ -n "${LOCK:-}" ]; then flock "$LOCK" "$@"; else "$@"; fi; }
field() { awk -F'\t' -v k="$2" '$1==k{print $2}' "$1"; }
row() {  # TSV of pcp_eval --normals -> "correct % | mean | median | unoriented"
    awk -v c="$(field "$1" correct_side)" -v m="$(field "$1" mean_angle_deg)" -v d="$(field "$1" median_angle_deg)" \
        -v u="$(field "$1" mean_unoriented_deg)" 'BEGIN{printf "%.2f %% | %.1f | %.1f | %.1f", 100*c, m, d, u}'
}
echo "| case | points | PCP: correct side | mean angle ° | median ° | unoriented ° | Open3D: correct side | mean angle ° | median ° | unoriented ° | PCP normals s | Open3D s |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
bench_kept_cases "$out" | while read -r c d input gt; do
    cp "$d/pcp.ply.ckpt" "$d/normals_mesh.ply.ckpt"
    cp "$d/pcp.ply.ckpt.prior" "$d/normals_mesh.ply.ckpt.prior"
    if ! locked "$BIN/pcp_reconstruct" "$input" -o "$d/normals_mesh.ply" --preset "$PRESET" --resume --keep-checkpoint \
            --normals "$d/normals_pcp.ply" --normals-from "${FROM:-mesh}" >"$d/normals_pcp.log" 2>&1; then
        echo "| $c | pcp_reconstruct failed (see $d/normals_pcp.log) |"
        continue
    fi
    pcp_s=$(sed -n 's/.*oriented normals (.*; \([0-9.e+-]*\) s).*/\1/p' "$d/normals_pcp.log" | tail -1 | awk '{printf "%.1f", $1}')
    if ! locked "$BIN/pcp_orient_open3d" "$input" "$d/normals_o3d.ply" >"$d/normals_o3d.log" 2>&1; then
        echo "| $c | pcp_orient_open3d failed (see $d/normals_o3d.log) |"
        continue
    fi
    o3d_s=$(sed -n 's/.* oriented in \([0-9.e+-]*\) s$/\1/p' "$d/normals_o3d.log" | awk '{printf "%.1f", $1}')
    "$BIN/pcp_eval" --normals "$d/normals_pcp.ply" "$gt" --tsv >"$d/normals_pcp.tsv"
    "$BIN/pcp_eval" --normals "$d/normals_o3d.ply" "$gt" --tsv >"$d/normals_o3d.tsv"
    echo "| $c | $(field "$d/normals_pcp.tsv" points) | $(row "$d/normals_pcp.tsv") | $(row "$d/normals_o3d.tsv") | $pcp_s | $o3d_s |"
done
