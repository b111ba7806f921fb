#!/usr/bin/env bash
# remesh_variants.sh: measures mesh-stage settings on the networks a benchmark run kept, without
# fitting again. For every case of MANIFEST with a ground-truth mesh whose OUT/<case>/pcp.ply.ckpt
# exists (a run_benchmarks.sh output made with `-- --keep-checkpoint`), each variant re-meshes the
# kept networks with `pcp_reconstruct INPUT --resume --keep-checkpoint --preset PRESET ARGS` into
# OUT/<case>/<name>.ply and pcp_eval scores it: L2-CD x 100 (p2s) and NC (shapenet), one line per
# case, the stored pcp.ply first.
#
# Usage: bench/remesh_variants.sh OUT "NAME:ARGS"...
#   e.g. bench/remesh_variants.sh /tmp/b1/out "cf:--winding-sign off" "all:--winding-sign on --smooth on"
# Environment: BIN (default <repo>/build/bin), MANIFEST (default <repo>/../shared/data/MANIFEST.tsv),
# PRESET (default: default), CASES (space-separated; default every case with kept networks).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/.." && pwd)
# shellcheck source=bench/lib_bench.sh
source "$here/lib_bench.sh"
bench_kept_networks_setup
[ $# -ge 2 ] || { sed -n 2,14p "$0"; exit 2; }
out=$1
shift
score() { bench_score "$BIN/pcp_eval" "$1" "$2"; }
bench_kept_cases "$out" | while read -r c d input gt; do
    line="$c | pcp $(score "$d/pcp.ply" "$gt")"
    for v in "$@"; do
        name=${v%%:*}
        args=${v#*:}
        [ "$name" != pcp ] || { echo "remesh_variants: the name 'pcp' is the stored mesh's" >&2; exit 2; }
        cp "$d/pcp.ply.ckpt" "$d/$name.ply.ckpt"
        prior_flag=""
        if [ -f "$d/pcp.ply.ckpt.prior" ]; then  # networks fitted against a self-prior
            cp "$d/pcp.ply.ckpt.prior" "$d/$name.ply.ckpt.prior"
            prior_flag="--self-prior"
        fi
        # shellcheck disable=SC2086
        if "$BIN/pcp_reconstruct" "$input" -o "$d/$name.ply" --preset "$PRESET" --resume --keep-checkpoint $prior_flag $args >"$d/$name.log" 2>&1; then
            line="$line | $name $(score "$d/$name.ply" "$gt")"
        else
            line="$line | $name failed (see $d/$name.log)"
        fi
    done
    echo "$line"
done
