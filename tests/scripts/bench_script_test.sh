#!/usr/bin/env bash
# Tests of bench/run_benchmarks.sh that need neither the data directory nor real runs (CTest label
# unit, a few seconds). Usage: bench_script_test.sh MODE WORKDIR [BIN_DIR]
#   dry-run  a tiny MANIFEST with a case whose files are missing (reported and skipped), a fine case
#            and a case without ground truth (ignored): checks the printed commands and exit codes.
#   fake-run the same MANIFEST run for real with fake tools (shell stand-ins that write a mesh file
#            and print pcp_eval --tsv lines; the fake Poisson fails on one case): checks the
#            generated Markdown section, that the rest of the file is untouched, that a second run
#            replaces the section, the failure row and the exit status. Exit 77 (skipped) without
#            /usr/bin/time.
#   eval-tsv the real pcp_eval --tsv on a tetrahedron against itself: every name the script reads.
set -uo pipefail
mode=$1
work=$2
bin=${3:-}
script="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)/bench/run_benchmarks.sh"

# shellcheck source=tests/script_check.sh
source "$(dirname "${BASH_SOURCE[0]}")/script_check.sh"

make_case_files "$work"
{
    printf 'name\tcategory\tinput\tgt_mesh\tgt_sdf\tpoints\tnote\n'
    printf 'lost_case\tabc\tlost/input.ply\tlost/gt.ply\t-\t100\tinput file missing\n'
    printf 'fine_case\tabc\tfine/input.ply\tfine/gt.ply\t-\t200\tall there\n'
    printf 'no_gt_case\tscan\tfine/input.ply\t-\t-\t200\tno ground truth\n'
} >"$work/data/MANIFEST.tsv"

case "$mode" in
dry-run)
    bash "$script" --manifest "$work/data/MANIFEST.tsv" --preset fast --out "$work/out" \
        --markdown "$work/BENCH.md" --bin /nonexistent/bin --dry-run -- --resolution 64 \
        >"$work/stdout" 2>"$work/stderr"
    rc=$?
    cat "$work/stdout" "$work/stderr"
    check "dry run exits 0" [ "$rc" -eq 0 ]
    check "missing input reported" contains "$work/stderr" "skip lost_case: missing input $work/data/lost/input.ply"
    check "no command for the missing case" lacks "$work/stdout" "lost_case"
    check "no command for the case without GT" lacks "$work/stdout" "no_gt_case"
    check "pcp_reconstruct command" contains "$work/stdout" \
        "/usr/bin/time -v -o $work/out/fine_case/pcp.time /nonexistent/bin/pcp_reconstruct $work/data/fine/input.ply -o $work/out/fine_case/pcp.ply --preset fast --resolution 64 >$work/out/fine_case/pcp.log 2>&1"
    check "Poisson command" contains "$work/stdout" \
        "/usr/bin/time -v -o $work/out/fine_case/poisson.time /nonexistent/bin/pcp_poisson_baseline $work/data/fine/input.ply $work/out/fine_case/poisson.ply >$work/out/fine_case/poisson.log 2>&1"
    for m in pcp poisson; do
        for p in p2s shapenet; do
            check "eval $m $p" contains "$work/stdout" \
                "/nonexistent/bin/pcp_eval $work/out/fine_case/$m.ply $work/data/fine/gt.ply --protocol $p --tsv >$work/out/fine_case/$m.$p.tsv"
        done
    done
    check "pcp_render command" contains "$work/stdout" \
        "/nonexistent/bin/pcp_render $work/data/fine/input.ply $work/out/fine_case/pcp.ply $work/out/fine_case/poisson.ply $work/data/fine/gt.ply --labels input\,pcp\,poisson\,gt -o $work/out/fine_case/fine_case.png >$work/out/fine_case/render.log 2>&1"
    check "seven commands in all" [ "$(grep -c '^/' "$work/stdout")" -eq 7 ]
    check "nothing written" [ ! -e "$work/BENCH.md" ] && check "no output dir" [ ! -e "$work/out" ]

    bash "$script" --manifest "$work/data/MANIFEST.tsv" --cases fine_case,nope --dry-run >/dev/null 2>"$work/stderr2"
    check "unknown case is a usage error" [ $? -eq 2 ]
    check "unknown case named" contains "$work/stderr2" "'nope' is not in"
    bash "$script" --manifest "$work/data/MANIFEST.tsv" --preset slow --dry-run >/dev/null 2>&1
    check "bad preset is a usage error" [ $? -eq 2 ]
    bash "$script" --manifest "$work/data/MANIFEST.tsv" --category scan --dry-run >/dev/null 2>&1
    check "a category without ground truth has no case: usage error" [ $? -eq 2 ]
    bash "$script" --manifest "$work/data/MANIFEST.tsv" --out "$(dirname "$script")/x" --dry-run >/dev/null 2>&1
    check "--out inside the repository is refused" [ $? -eq 2 ]
    ;;
fake-run)
    [ -x /usr/bin/time ] || { echo "skipped: no /usr/bin/time (Debian package 'time')"; exit 77; }
    mkdir -p "$work/bin"
    # Fake tools: pcp_reconstruct and the Poisson baseline write OUT; the fake Poisson fails with
    # exit 3 when FAKE_POISSON_FAILS is set. pcp_eval prints --tsv lines whose values depend on
    # the mesh's name (pcp better than poisson).
    cat >"$work/bin/pcp_reconstruct" <<'EOF'
#!/usr/bin/env bash
out=""; while [ $# -gt 0 ]; do [ "$1" = -o ] && out=$2; shift; done
echo "fake reconstruct"; echo mesh >"$out"
EOF
    cat >"$work/bin/pcp_poisson_baseline" <<'EOF'
#!/usr/bin/env bash
[ -n "${FAKE_POISSON_FAILS:-}" ] && { echo "fake poisson: error" >&2; exit 3; }
echo mesh >"$2"
EOF
    cat >"$work/bin/pcp_eval" <<'EOF'
#!/usr/bin/env bash
case "$1" in *pcp.ply) l2=0.25; nc=0.93 ;; *o3d_d9.ply) l2=0.8; nc=0.80 ;; *o3d_*) l2=1.2; nc=0.75 ;; *) l2=1.5; nc=0.71 ;; esac
p=$4
printf 'protocol\t%s\t-\nsamples\t10000\t-\nframe_scale\t1\t-\n' "$p"
printf 'chamfer_l1\t0.0123\t0.002\nchamfer_l2\t0.0025\t4e-05\nchamfer_l2_x100\t%s\t0.004\n' "$l2"
printf 'normal_consistency\t%s\t0.98\nhausdorff\t0.1\t0.01\n' "$nc"
printf 'fscore@0.002\t0.41\t0.56\nfscore@0.004\t0.77\t0.96\nscene_error\t0.01\t-\n'
EOF
    # The fake pcp_render records its arguments and writes OUT; it fails when FAKE_RENDER_FAILS is set.
    cat >"$work/bin/pcp_render" <<'EOF'
#!/usr/bin/env bash
[ -n "${FAKE_RENDER_FAILS:-}" ] && { echo "fake render: error" >&2; exit 1; }
out=""; args=("$@"); while [ $# -gt 0 ]; do [ "$1" = -o ] && out=$2; shift; done
echo "${args[*]}" >"$out.args"; echo png >"$out"
EOF
    chmod +x "$work/bin/"*
    md="$work/BENCH.md"
    printf '# Title\n\nhand-written text above\n' >"$md"
    bash "$script" --manifest "$work/data/MANIFEST.tsv" --preset fast --out "$work/out" --markdown "$md" \
        --bin "$work/bin" >"$work/stdout" 2>"$work/stderr"
    rc=$?
    cat "$work/stderr"
    check "first run exits 0" [ "$rc" -eq 0 ]
    check "text above kept" contains "$md" "hand-written text above"
    check "one BEGIN marker" [ "$(grep -c '^<!-- BEGIN run_benchmarks' "$md")" -eq 1 ]
    check "command line at the top" contains "$md" "bench/run_benchmarks.sh --manifest $work/data/MANIFEST.tsv --preset fast"
    check "PCP row" contains "$md" '| fine_case | 200 | PCP (`--preset fast`) |'
    check "PCP metrics (L2-CD, CD-L1, NC, F)" contains "$md" '| 0.25 | 0.01230 | 0.930 | 0.410 | 0.770 | yes |'
    check "floor row" contains "$md" '| fine_case | 200 | floor (GT vs GT) |  |  | 0.004 | 0.00200 | 0.980 | 0.560 | 0.960 |  |'
    check "skipped row" contains "$md" "| lost_case | 100 | - | skipped: missing input $work/data/lost/input.ply"
    check "ABC summary next to the paper" contains "$md" '| ABC (Points2Surf scans) | 1 | 0.25 | 1.5 | 0.930 | 0.710 | 1 of 1 | 0.200 | 0.48 | 2.49 |'
    check "results.tsv" contains "$work/out/results.tsv" $'fine_case\tpcp\tok\t'
    check "picture next to the meshes" [ -s "$work/out/fine_case/fine_case.png" ]
    check "picture of input, PCP, Poisson, GT" contains "$work/out/fine_case/fine_case.png.args" \
        "$work/data/fine/input.ply $work/out/fine_case/pcp.ply $work/out/fine_case/poisson.ply $work/data/fine/gt.ply --labels input,pcp,poisson,gt -o $work/out/fine_case/fine_case.png"
    check "no picture for the skipped case" [ ! -e "$work/out/lost_case" ]

    # Second run: the Poisson baseline fails; text added below the section must survive.
    printf '\nhand-written text below\n' >>"$md"
    FAKE_POISSON_FAILS=1 bash "$script" --manifest "$work/data/MANIFEST.tsv" --preset fast --out "$work/out2" \
        --markdown "$md" --bin "$work/bin" >"$work/stdout" 2>"$work/stderr"
    rc=$?
    cat "$work/stderr"
    check "a failed run makes the exit status 1" [ "$rc" -eq 1 ]
    check "failure row" contains "$md" "| Poisson (CGAL, jet + MST normals) | failed (exit 3, see $work/out2/fine_case/poisson.log) |"
    check "no comparison without Poisson" contains "$md" '| 0.25 | 0.01230 | 0.930 | 0.410 | 0.770 | - |'
    check "still one section" [ "$(grep -c '^<!-- END run_benchmarks' "$md")" -eq 1 ]
    check "old section replaced" lacks "$md" "$work/out/fine_case"
    check "text above still kept" contains "$md" "hand-written text above"
    check "text below kept" contains "$md" "hand-written text below"
    check "no temp file left" [ -z "$(find "$work" -maxdepth 1 -name '.BENCH.md.*')" ]
    check "picture without the missing Poisson mesh" contains "$work/out2/fine_case/fine_case.png.args" \
        "$work/out2/fine_case/pcp.ply $work/data/fine/gt.ply --labels input,pcp,gt -o"

    # Third run: pcp_render fails; the benchmark still succeeds, with a warning.
    FAKE_RENDER_FAILS=1 bash "$script" --manifest "$work/data/MANIFEST.tsv" --preset fast --out "$work/out3" \
        --markdown "$md" --bin "$work/bin" >"$work/stdout" 2>"$work/stderr"
    rc=$?
    cat "$work/stderr"
    check "a failed picture does not fail the run" [ "$rc" -eq 0 ]
    check "failed picture warned" contains "$work/stderr" "warning: fine_case: pcp_render failed (exit 1, see $work/out3/fine_case/render.log); no picture"
    check "no picture left" [ ! -e "$work/out3/fine_case/fine_case.png" ]

    # Fourth run: with Open3D's Poisson built, depths 8, 9 and 10 run; the best baseline (depth 9
    # here, by the fake L2-CD) is marked, compared with PCP and drawn.
    cp -r "$work/bin" "$work/bin4"
    printf '#!/usr/bin/env bash\necho "depth $3" >"$2.depth"; echo mesh >"$2"\n' >"$work/bin4/pcp_poisson_open3d"
    chmod +x "$work/bin4/pcp_poisson_open3d"
    bash "$script" --manifest "$work/data/MANIFEST.tsv" --preset fast --out "$work/out4" \
        --markdown "$md" --bin "$work/bin4" >"$work/stdout" 2>"$work/stderr"
    rc=$?
    cat "$work/stderr"
    check "fourth run exits 0" [ "$rc" -eq 0 ]
    for d in 8 9 10; do
        check "Open3D at depth $d" contains "$work/out4/fine_case/o3d_d$d.ply.depth" "depth $d"
    done
    check "best baseline marked" contains "$md" "| screened Poisson (Open3D, depth 9, PCA-30 normals, tangent-plane orientation, 1 % density trim) **(best baseline)** |"
    check "CGAL not marked" contains "$md" "| Poisson (CGAL, jet + MST normals) | "
    check "summary against the best baseline" contains "$md" '| ABC (Points2Surf scans) | 1 | 0.25 | 0.8 | 0.930 | 0.800 | 1 of 1 |'
    check "picture of input, PCP, the best baseline, GT" contains "$work/out4/fine_case/fine_case.png.args" \
        "$work/out4/fine_case/pcp.ply $work/out4/fine_case/o3d_d9.ply $work/data/fine/gt.ply --labels input,pcp,o3d_d9,gt -o"
    ;;
eval-tsv)
    [ -n "$bin" ] || { echo "eval-tsv needs BIN_DIR"; exit 2; }
    cat >"$work/tet.ply" <<'EOF'
ply
format ascii 1.0
element vertex 4
property float x
property float y
property float z
element face 4
property list uchar int vertex_indices
end_header
0 0 0
1 0 0
0 1 0
0 0 1
3 0 2 1
3 0 1 3
3 0 3 2
3 1 2 3
EOF
    for p in p2s shapenet; do
        "$bin/pcp_eval" "$work/tet.ply" "$work/tet.ply" --protocol "$p" --samples 2000 --tsv >"$work/$p.tsv"
        check "pcp_eval --tsv $p exits 0" [ $? -eq 0 ]
        cat "$work/$p.tsv"
        for name in chamfer_l1 chamfer_l2_x100 normal_consistency fscore@0.002 fscore@0.004; do
            check "$p: $name has a value and a floor" \
                awk -F'\t' -v n="$name" '$1 == n && NF == 3 && $2 != "-" && $3 != "-" { f = 1 } END { exit !f }' "$work/$p.tsv"
        done
        check "$p: protocol line" contains "$work/$p.tsv" $'protocol\t'"$p"$'\t-'
    done
    "$bin/pcp_eval" "$work/tet.ply" "$work/tet.ply" --tsv --json >/dev/null 2>&1
    check "--tsv with --json is a usage error" [ $? -eq 2 ]
    ;;
*) echo "unknown mode $mode"; exit 2 ;;
esac
exit $failed
