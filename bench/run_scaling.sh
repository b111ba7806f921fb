#!/usr/bin/env bash
# run_scaling.sh: how pcp_reconstruct's time and memory grow with the number of input points
# (issue 7). Samples the embedded default shape (a block with sharp edges, a through-hole and a
# thin fin; the main job of the README) at each size with --builtin-points, reconstructs it under
# GNU `/usr/bin/time -v`, and prints one Markdown row per size with the stage times of the run's
# summary line, the SDF evaluations per second and the peak memory. Nothing is written into the
# repository.
#
# Usage: bench/run_scaling.sh [options] [-- extra pcp_reconstruct options]
#   --points "N1 N2 ..."  input sizes (default: "10000 30000 100000 300000 1000000")
#   --preset NAME         pcp_reconstruct preset (default: default)
#   --bin DIR             where pcp_reconstruct is (default: <repo>/build/bin)
#   --out DIR             meshes and logs (default: a new temp dir in ${TMPDIR:-/tmp})
#   --lock FILE           run every reconstruction under `flock FILE`
#   -h, --help            this text
# Exit status: 0 every run succeeded, 1 a run failed (its row says so), 2 bad command line.
set -euo pipefail
prog=run_scaling.sh
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
points="10000 30000 100000 300000 1000000"
preset=default
bin="$repo/build/bin"
out=""
lock=()
usage() { sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d' | sed 's/^# \{0,1\}//'; }
die_usage() { echo "$prog: $*" >&2; echo "$prog: see --help" >&2; exit 2; }
while [ $# -gt 0 ]; do
    case $1 in
        --points) [ $# -ge 2 ] || die_usage "--points needs a value"; points=$2; shift 2 ;;
        --preset) [ $# -ge 2 ] || die_usage "--preset needs a value"; preset=$2; shift 2 ;;
        --bin) [ $# -ge 2 ] || die_usage "--bin needs a value"; bin=$2; shift 2 ;;
        --out) [ $# -ge 2 ] || die_usage "--out needs a value"; out=$2; shift 2 ;;
        --lock) [ $# -ge 2 ] || die_usage "--lock needs a value"; lock=(flock "$2"); shift 2 ;;
        -h | --help) usage; exit 0 ;;
        --) shift; break ;;
        *) die_usage "unknown option '$1'" ;;
    esac
done
for n in $points; do
    [[ $n =~ ^[0-9]+$ ]] || die_usage "--points: '$n' is not a number"
done
[ -x "$bin/pcp_reconstruct" ] || die_usage "$bin/pcp_reconstruct not found (build first, or --bin)"
[ -x /usr/bin/time ] || die_usage "/usr/bin/time not found (apt-get install time)"
[ -n "$out" ] || out=$(mktemp -d "${TMPDIR:-/tmp}/pcp_scaling.XXXXXX")
mkdir -p "$out"

echo "pcp_reconstruct --preset $preset --builtin-points N $*; logs in $out; $(nproc) cores, $(date -u +%Y-%m-%d)"
echo
echo "| points | total s | s per 100k points | denoise s | self-prior s | query net s | SDF grid s | SDF evaluations | evaluations/s | marching cubes s | peak MiB |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
status=0
for n in $points; do
    log="$out/scale_$n.log"
    if ! ${lock[@]+"${lock[@]}"} /usr/bin/time -v -o "$out/scale_$n.time" "$bin/pcp_reconstruct" --preset "$preset" \
        --builtin-points "$n" -o "$out/scale_$n.ply" "$@" >"$log" 2>&1; then
        echo "| $n | failed (see $log) | | | | | | | | | |"
        status=1
        continue
    fi
    # The summary line: "| read X s | denoise X s (..) | prior X s (..) | query net X s (..) | SDF grid X s (E evaluations) | marching cubes X s | total X s | ..."
    awk -v n="$n" -v rss="$(awk '/Maximum resident set size/ { printf "%.0f", $NF / 1024 }' "$out/scale_$n.time")" '
        /^\| read [0-9]/ {
            split($0, f, "|")
            for (i in f) {
                if (f[i] ~ /^ denoise /) { split(f[i], a, " "); den = a[2] }
                if (f[i] ~ /^ prior /) { split(f[i], a, " "); pri = a[2] }
                if (f[i] ~ /^ query net /) { split(f[i], a, " "); qn = a[3] }
                if (f[i] ~ /^ SDF grid /) { split(f[i], a, " "); grid = a[3]; ev = substr(a[5], 2) }
                if (f[i] ~ /^ marching cubes /) { split(f[i], a, " "); mc = a[3] }
                if (f[i] ~ /^ total /) { split(f[i], a, " "); tot = a[2] }
            }
            printf "| %d | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %d | %.0f | %.2f | %s |\n",
                   n, tot, tot / n * 1e5, den, pri, qn, grid, ev, ev / grid, mc, rss
        }' "$log"
done
exit "$status"
