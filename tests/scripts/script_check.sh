# Assertions shared by the shell tests of the bench scripts (sourced, not run). After sourcing:
#   check DESCRIPTION COMMAND...   runs COMMAND, prints "ok: ..." or "FAILED: ..." (then failed=1)
#   contains FILE TEXT, lacks FILE TEXT   fixed-string grep, for use with check
failed=0
check() {
    local what=$1; shift
    if "$@"; then echo "ok: $what"; else echo "FAILED: $what"; failed=1; fi
}
contains() { grep -qF -- "$2" "$1"; }
lacks() { ! grep -qF -- "$2" "$1"; }
#   make_case_files WORK   a fresh WORK/data with fine/{input,gt}.ply and lost/gt.ply (no input)
make_case_files() {
    rm -rf "$1"
    mkdir -p "$1/data/fine" "$1/data/lost"
    printf 'dummy\n' >"$1/data/fine/input.ply"
    printf 'dummy\n' >"$1/data/fine/gt.ply"
    printf 'dummy\n' >"$1/data/lost/gt.ply"   # its input.ply is missing
}
