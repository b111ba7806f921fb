#!/usr/bin/env bash
# Full disks (issue 19): with a file-size limit (ulimit -f) every write of the tools fails part-way
# - the mesh, the --normals file, a query-network checkpoint, a prior file, a training checkpoint -
# and each failure must be a non-zero exit with one error line naming the file, no output file, no
# temporary file left behind, and the input untouched. Also too little memory: refused up front.
#
# Usage: full_disk_test.sh BIN_DIR WORK_DIR
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=tests/scripts/script_check.sh
source "$here/script_check.sh"
[ $# -eq 2 ] || { sed -n 2,7p "$0"; exit 2; }
bin=$(cd "$1" && pwd)
work=$2
rm -rf "$work"
mkdir -p "$work"
cd "$work" || exit 1

# Inputs, written without a limit: a cloud and a small prior trained on it.
"$bin/pcp_reconstruct" --builtin-points 4000 --preset fast --steps 1 --prior-epochs 1 --width 16 --resolution 16 \
    --threads 1 -q -o unused.ply --normals cloud.ply >/dev/null 2>&1
check "input cloud written" test -s cloud.ply
"$bin/pcp_train" cloud.ply -o prior.pcpm --preset fast --width 32 --depth 2 --condition 32 --grid 2 --steps 30 \
    --threads 1 -q >/dev/null 2>&1
check "input prior written" test -s prior.pcpm
inputs_sum=$(md5sum cloud.ply prior.pcpm)

# expect_full NAME LIMIT_KIB FILE COMMAND...: runs COMMAND under `ulimit -f LIMIT_KIB` (in a
# subshell); it must fail with one error line naming FILE, and leave neither FILE nor a temporary.
expect_full() {
    local name=$1 limit=$2 file=$3
    shift 3
    rm -f "$file"
    ( ulimit -f "$limit"; "$@" ) >"$name.log" 2>&1
    local status=$?
    check "$name: non-zero exit (got $status)" test "$status" -ne 0 -a "$status" -lt 128
    check "$name: the error names $file and the cause" grep -qE "error: .*$file.*(File too large|write failed)" "$name.log"
    check "$name: one error line" test "$(grep -c 'error' "$name.log")" -eq 1
    check "$name: no $file" test ! -e "$file"
    check "$name: no temporary file" test -z "$(find . -name '.*.tmp-*' -print -quit)"
    check "$name: inputs untouched" test "$(md5sum cloud.ply prior.pcpm)" = "$inputs_sum"
}

run=("$bin/pcp_reconstruct" cloud.ply --prior prior.pcpm --preset fast --steps 60 --width 32 --resolution 48
     --threads 1 -q)
# The mesh (hundreds of KiB) does not fit in 64 KiB; the checkpoints (a few KiB) are off.
expect_full mesh 64 out.ply "${run[@]}" -o out.ply --checkpoint-every 0
# A coarse mesh (tens of KiB) fits in 128 KiB, the ascii normals of 4000 points (about 250 KiB) do
# not (the mesh, written first and complete, stays).
expect_full normals 128 normals.xyz "$bin/pcp_reconstruct" cloud.ply --prior prior.pcpm --preset fast --steps 60 \
    --width 32 --resolution 16 --threads 1 -q -o out2.ply --checkpoint-every 0 --normals normals.xyz
# A query-network checkpoint (every 20 steps) does not fit in 8 KiB.
expect_full checkpoint 8 out3.ply.ckpt "${run[@]}" -o out3.ply --checkpoint-every 20
check "checkpoint: no mesh either" test ! -e out3.ply
# pcp_train: the prior file (a PointNet of 1024 features: about 2 MiB) does not fit in 256 KiB;
# its training checkpoints are off.
expect_full prior 256 out.pcpm "$bin/pcp_train" cloud.ply -o out.pcpm --preset fast --width 32 --depth 2 \
    --condition 32 --grid 2 --steps 20 --checkpoint-every 0 --threads 1 -q
# pcp_train's training checkpoint (every 10 steps) does not fit either.
expect_full train_checkpoint 256 out2.pcpm.ckpt "$bin/pcp_train" cloud.ply -o out2.pcpm --preset fast --width 32 \
    --depth 2 --condition 32 --grid 2 --steps 20 --checkpoint-every 10 --threads 1 -q
check "train_checkpoint: no prior file either" test ! -e out2.pcpm

# Too little memory (PCP_MEMORY_LIMIT_MIB stands for a small machine): refused before any work,
# naming the input and the memory it needs, nothing written.
PCP_MEMORY_LIMIT_MIB=200 "${run[@]}" -o out4.ply >memory.log 2>&1
check "memory: exit 1" test $? -eq 1
check "memory: the error names the input and the need" grep -qE "error: cloud.ply: fitting 4000 points needs about [0-9]+ MiB of memory, 200 MiB are available" memory.log
check "memory: no mesh" test ! -e out4.ply
PCP_MEMORY_LIMIT_MIB=0.5 "${run[@]}" -o out4.ply >memory_read.log 2>&1
check "memory: a file too large to read is refused before reading" grep -q "error: cloud.ply: reading this file needs about" memory_read.log

# The same runs without the limit succeed (the failures above were the limit's).
check "mesh written without the limit" "${run[@]}" -o out.ply --checkpoint-every 0
exit "$failed"
