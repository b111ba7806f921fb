#!/usr/bin/env bash
# surface_fit_sweep.sh: measures settings of the surface fit (include/pcp/mesh/surface/surface_fit.hpp) on
# the PCP meshes a benchmark run stored, without fitting the networks again. For every case of
# OUT/results.tsv that has OUT/<case>/pcp.ply made with --surface-fit off (or by a build before
# the surface fit existed), bench_surface_fit applies each setting to that mesh (with the input
# denoised as pcp_reconstruct's --denoise auto does) and pcp_eval scores it: L2-CD x 100 (p2s) /
# NC (shapenet), before -> after, one line per case and setting.
#
# Usage: bench/surface_fit_sweep.sh OUT "ITER NEIGHBORS BANDWIDTH RELAX DENOISE MIN_SUPPORTED SHRINK"...
#   OUT      a run_benchmarks.sh output directory
#   setting  the arguments of bench_surface_fit after MESH CLOUD OUT, e.g. "10 16 1.0 0.5 auto 0.5 1"
# Environment: BIN (default <repo>/build/bin), MANIFEST (default <repo>/../shared/data/MANIFEST.tsv),
# CASES (space-separated; default every case with a stored pcp.ply and a ground-truth mesh).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/.." && pwd)
BIN=${BIN:-$repo/build/bin}
MANIFEST=${MANIFEST:-$repo/../shared/data/MANIFEST.tsv}
[ $# -ge 2 ] || { sed -n 2,16p "$0"; exit 2; }
out=$1
shift
data=$(dirname "$MANIFEST")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# shellcheck source=bench/lib_bench.sh
source "$here/lib_bench.sh"
score() { bench_score "$BIN/pcp_eval" "$1" "$2"; }
cases=${CASES:-$(awk -F'\t' 'NR>1 && $4!="-"{print $1}' "$MANIFEST")}
for setting in "$@"; do
    echo "== setting: $setting"
    for c in $cases; do
        mesh=$out/$c/pcp.ply
        [ -f "$mesh" ] || continue
        input=$data/$(awk -F'\t' -v c="$c" '$1==c{print $3}' "$MANIFEST")
        gt=$data/$(awk -F'\t' -v c="$c" '$1==c{print $4}' "$MANIFEST")
        # shellcheck disable=SC2086
        info=$("$BIN/bench_surface_fit" "$mesh" "$input" "$tmp/fit.ply" $setting)
        echo "$c | $(score "$mesh" "$gt") -> $(score "$tmp/fit.ply" "$gt") | $info"
    done
done
