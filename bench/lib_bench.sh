# lib_bench.sh: the bash functions shared by bench/run_benchmarks.sh and bench/run_ablations.sh
# (sourced, not run): usage errors, the data MANIFEST.tsv (columns found by name) and the choice of
# cases, the --out check (never inside the repository unless git-ignored), running commands (or
# printing them in a dry run) under an optional lock, GNU time reports, number formatting, the
# machine description, atomic writes of generated files, and the short score of the sweep scripts.
#
# The caller sets before use: prog (name in messages), repo (repository root), and, for the
# functions that need them, dry_run (0/1), lock_prefix (array), bin_dir, manifest, out_dir, R
# (associative array of results).

# bench_score PCP_EVAL MESH GT: "L2-CD x 100 (p2s) / NC (shapenet)" of MESH against GT, for the sweep
# scripts (surface_fit_sweep.sh, remesh_variants.sh).
bench_score() {
    local l2 nc
    l2=$("$1" "$2" "$3" --protocol p2s --tsv | awk '$1=="chamfer_l2_x100"{print $2}')
    nc=$("$1" "$2" "$3" --protocol shapenet --tsv | awk '$1=="normal_consistency"{print $2}')
    printf "%.4f / %.3f" "$l2" "$nc"
}

# bench_kept_networks_setup: for the scripts that re-mesh a benchmark run's kept networks
# (remesh_variants.sh, run_normals.sh; `repo` set): BIN, MANIFEST, PRESET from the environment or
# their defaults, `data` (the manifest's directory); bench_case_file CASE COLUMN (3 input, 4 gt):
# the case's file.
bench_kept_networks_setup() {
    BIN=${BIN:-$repo/build/bin}
    MANIFEST=${MANIFEST:-$repo/../shared/data/MANIFEST.tsv}
    PRESET=${PRESET:-default}
    data=$(dirname "$MANIFEST")
}
bench_case_file() { echo "$data/$(awk -F'\t' -v c="$1" -v k="$2" '$1==c{print $k}' "$MANIFEST")"; }
# bench_kept_cases OUT: one line "CASE DIR INPUT GT" per case of $CASES (default: every case with a
# GT mesh) whose OUT/CASE/pcp.ply.ckpt exists.
bench_kept_cases() {
    local c
    for c in ${CASES:-$(awk -F'\t' 'NR>1 && $4!="-"{print $1}' "$MANIFEST")}; do
        [ -f "$1/$c/pcp.ply.ckpt" ] || continue
        echo "$c $1/$c $(bench_case_file "$c" 3) $(bench_case_file "$c" 4)"
    done
}

die_usage() { echo "$prog: $*" >&2; echo "$prog: see --help" >&2; exit 2; }
need_value() { [ $# -ge 2 ] && [ -n "$2" ] || die_usage "$1 needs a value"; }

# bench_common_option ARGS... : parses one option shared by both scripts (--manifest, --cases,
# --preset, --out, --markdown, --bin, --lock, --dry-run) into the caller's variables; sets
# bench_shift to the number of words it used, 0 if $1 is not one of them.
bench_common_option() {
    bench_shift=2
    case "$1" in
        --manifest) need_value "$@"; manifest=$2 ;;
        --cases) need_value "$@"; cases_filter=$2 ;;
        --preset) need_value "$@"; preset=$2 ;;
        --out) need_value "$@"; out_dir=$2 ;;
        --markdown) need_value "$@"; markdown=$2 ;;
        --bin) need_value "$@"; bin_dir=$2 ;;
        --lock) need_value "$@"; lock_file=$2 ;;
        --dry-run) dry_run=1; bench_shift=1 ;;
        *) bench_shift=0 ;;
    esac
}

# bench_check_preset : the --preset value is one pcp_reconstruct knows.
bench_check_preset() {
    case "$preset" in paper | default | fast) ;; *) die_usage "--preset must be paper, default or fast (got '$preset')" ;; esac
}

# bench_command_line SCRIPT ARGS... : the command as typed; words that need no quoting are shown as
# they are (printf %q would escape the comma of --cases a,b).
bench_command_line() {
    local line=$1 arg; shift
    for arg in "$@"; do
        if [[ "$arg" =~ ^[A-Za-z0-9_./,=:+@%-]+$ ]]; then line+=" $arg"; else line+=" $(printf '%q' "$arg")"; fi
    done
    printf '%s' "$line"
}

# bench_read_manifest FILE : fills names, categories, inputs, gts, npoints (one entry per data row;
# "-" for an empty field) and data_dir (the manifest's directory, which its paths are relative to).
bench_read_manifest() {
    local file=$1 line i name
    [ -f "$file" ] || die_usage "manifest not found: $file"
    data_dir=$(cd "$(dirname "$file")" && pwd)
    declare -A col=()
    local header=() f=()
    {
        # Tabs are IFS whitespace (runs of them would merge): split on a non-whitespace separator.
        IFS= read -r line || die_usage "$file is empty"
        IFS=$'\x1f' read -r -a header <<<"${line//$'\t'/$'\x1f'}"
        for i in "${!header[@]}"; do col[${header[$i]%$'\r'}]=$i; done
        for name in name category input gt_mesh points; do
            [ -n "${col[$name]+x}" ] || die_usage "$file: no column '$name'"
        done
        names=() categories=() inputs=() gts=() npoints=()
        while IFS= read -r line || [ -n "$line" ]; do
            line=${line%$'\r'}
            [ -n "$line" ] || continue
            [[ "$line" == \#* ]] && { line=""; continue; }
            IFS=$'\x1f' read -r -a f <<<"${line//$'\t'/$'\x1f'}"
            names+=("${f[${col[name]}]:-}")
            categories+=("${f[${col[category]}]:-}")
            inputs+=("${f[${col[input]}]:--}")
            gts+=("${f[${col[gt_mesh]}]:--}")
            npoints+=("${f[${col[points]}]:--}")
            line=""
        done
    } <"$file"
}

# bench_select_cases CASES CATEGORY : fills selected (manifest row indices) with the cases named in
# the comma-separated CASES (all if empty) of CATEGORY (any if empty) that have a ground-truth mesh.
bench_select_cases() {
    local cases_filter=$1 category_filter=$2 c n i found
    local requested=()
    declare -A wanted=()
    if [ -n "$cases_filter" ]; then
        IFS=',' read -r -a requested <<<"$cases_filter"
        for c in "${requested[@]}"; do
            found=0
            for n in "${names[@]}"; do [ "$n" = "$c" ] && found=1; done
            [ $found -eq 1 ] || die_usage "--cases: '$c' is not in $manifest"
            wanted[$c]=1
        done
    fi
    selected=()
    for i in "${!names[@]}"; do
        [ -n "$cases_filter" ] && [ -z "${wanted[${names[$i]}]+x}" ] && continue
        [ -n "$category_filter" ] && [ "${categories[$i]}" != "$category_filter" ] && continue
        if [ "${gts[$i]}" = "-" ]; then
            # Cases without ground truth are not benchmarks; say so only when they were asked for.
            [ -n "$cases_filter" ] && echo "$prog: skip ${names[$i]}: no ground-truth mesh in the manifest" >&2
            continue
        fi
        selected+=("$i")
    done
    [ ${#selected[@]} -gt 0 ] || die_usage "no case with a ground-truth mesh matches the filters"
}

# bench_prepare_out_dir PREFIX : a new temp dir for out_dir when none was given (dry run: only its
# pattern), and the refusal of an out_dir inside the repository that git does not ignore.
bench_prepare_out_dir() {
    local prefix=$1 out_abs
    if [ -z "$out_dir" ]; then
        if [ "$dry_run" -eq 1 ]; then out_dir="${TMPDIR:-/tmp}/$prefix.XXXXXX"
        else out_dir=$(mktemp -d "${TMPDIR:-/tmp}/$prefix.XXXXXX") || die_usage "cannot create a temp dir"; fi
    fi
    out_abs=$(realpath -m "$out_dir")
    case "$out_abs/" in
        "$repo"/*)
            # Meshes of the data must never become part of the repository: only git-ignored places
            # (such as build/) are allowed inside it.
            git -C "$repo" check-ignore -q "$out_abs" 2>/dev/null ||
                die_usage "--out $out_dir is inside the repository and not git-ignored; the data's meshes must stay out of it" ;;
    esac
    if [ "$dry_run" -eq 0 ]; then mkdir -p "$out_dir" || die_usage "cannot create $out_dir"; fi
}

# show_command CMD... : the command as a copy-pastable line.
show_command() {
    local line="" a
    for a in "$@"; do line+="$(printf '%q' "$a") "; done
    printf '%s' "${line% }"
}

# run_logged LOG CMD... : runs CMD with stdout+stderr into LOG (dry run: prints it); returns its status.
run_logged() {
    local log=$1; shift
    if [ "$dry_run" -eq 1 ]; then
        echo "$(show_command ${lock_prefix[@]+"${lock_prefix[@]}"} "$@") >$(printf '%q' "$log") 2>&1"
        return 0
    fi
    ${lock_prefix[@]+"${lock_prefix[@]}"} "$@" >"$log" 2>&1
}

# run_to LOG ERR CMD... : stdout into LOG, stderr into ERR.
run_to() {
    local log=$1 err=$2; shift 2
    if [ "$dry_run" -eq 1 ]; then
        echo "$(show_command ${lock_prefix[@]+"${lock_prefix[@]}"} "$@") >$(printf '%q' "$log") 2>$(printf '%q' "$err")"
        return 0
    fi
    ${lock_prefix[@]+"${lock_prefix[@]}"} "$@" >"$log" 2>"$err"
}

# read_time_report FILE KEY : R[KEY|time] wall seconds and R[KEY|rss] peak RSS (MiB) from `time -v -o FILE`.
read_time_report() {
    local file=$1 key=$2
    R[$key|time]=$(awk '/Elapsed \(wall clock\) time/ { n = split($NF, a, ":"); s = 0;
                        for (i = 1; i <= n; ++i) s = s * 60 + a[i]; printf "%.1f", s }' "$file" 2>/dev/null)
    R[$key|rss]=$(awk '/Maximum resident set size/ { printf "%.0f", $NF / 1024 }' "$file" 2>/dev/null)
    [ -n "${R[$key|time]}" ] || R[$key|time]="-"
    [ -n "${R[$key|rss]}" ] || R[$key|rss]="-"
}

# num FORMAT VALUE : printf through awk; "-" for a missing value.
num() { if [ -z "${2:-}" ] || [ "$2" = "-" ]; then echo "-"; else awk -v f="$1" -v v="$2" 'BEGIN { printf f, v }'; fi; }
# get KEY : R[KEY] or "-".
get() { local k=$1; echo "${R[$k]:--}"; }

# machine_lines : Markdown bullets: date, machine, compiler and build type, commit, data and output.
machine_lines() {
    local cpu cores isa mem cxx="" compiler="unknown" build_type="unknown" cache commit dirty=""
    cpu=$(awk -F': ' '/^model name/ { print $2; exit }' /proc/cpuinfo 2>/dev/null)
    cores=$(nproc 2>/dev/null)
    isa=$(awk '/^flags/ { for (i = 3; i <= NF; ++i) if ($i ~ /^(avx2|fma|avx512f|avx512_bf16|amx_tile)$/) s = s " " $i; print substr(s, 2); exit }' /proc/cpuinfo 2>/dev/null)
    local isa_text="" flag label
    for flag in avx2:AVX2 fma:FMA avx512f:AVX-512 avx512_bf16:AVX512-BF16 amx_tile:AMX; do
        label=${flag#*:}
        if [[ " $isa " == *" ${flag%%:*} "* ]]; then isa_text+=", $label"; else isa_text+=", no $label"; fi
    done
    isa_text=${isa_text#, }
    mem=$(awk '/^MemTotal/ { printf "%.0f GiB", $2 / 1048576 }' /proc/meminfo 2>/dev/null)
    cache="$bin_dir/../CMakeCache.txt"
    if [ -f "$cache" ]; then
        cxx=$(sed -n 's/^CMAKE_CXX_COMPILER:[A-Z]*=//p' "$cache")
        build_type=$(sed -n 's/^CMAKE_BUILD_TYPE:[A-Z]*=//p' "$cache")
        [ -n "$cxx" ] && compiler=$("$cxx" --version 2>/dev/null | head -n 1)
    fi
    commit=$(git -C "$repo" rev-parse --short=12 HEAD 2>/dev/null || echo unknown)
    [ -n "$(git -C "$repo" status --porcelain --untracked-files=no 2>/dev/null)" ] && dirty=" (with uncommitted changes)"
    echo "- Date: $(date -u '+%Y-%m-%d %H:%M UTC')"
    echo "- Machine: ${cpu:-unknown CPU}, $cores cores ($isa_text), ${mem:-unknown memory}; $(uname -sr)"
    echo "- Compiler: $compiler; build type ${build_type:-unknown} (\`$bin_dir\`)"
    echo "- libpcp commit: \`$commit\`$dirty"
    echo "- Data: \`$(realpath "$manifest")\`; meshes and logs: \`$out_dir\`"
}

# replace_file_atomically SRC DEST : DEST gets SRC's content through a temp file in DEST's directory
# and a rename (DEST's mode is kept; a new DEST gets 644). SRC is left in place.
replace_file_atomically() {
    local src=$1 dest=$2 tmp
    tmp=$(mktemp "$(dirname "$dest")/.$(basename "$dest").XXXXXX") || return 1
    cat "$src" >"$tmp" || { rm -f "$tmp"; return 1; }
    if [ -f "$dest" ]; then chmod --reference="$dest" "$tmp" 2>/dev/null; else chmod 644 "$tmp"; fi
    mv -f "$tmp" "$dest"
}
