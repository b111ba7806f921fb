#!/usr/bin/env bash
# Interrupted runs, proven with real signals (issue 19): pcp_reconstruct and pcp_train are killed
# with SIGKILL at a random point of each stage, resumed with --resume, and the final mesh / prior
# file must be byte-identical to an uninterrupted run's (one thread, fp32). A checkpoint truncated
# or corrupted on disk must be refused with a one-line error naming it, leaving no output.
#
# Usage: kill_resume_test.sh BIN_DIR WORK_DIR [SEED]
# The random kill points come from SEED (default: the clock); the seed is printed first, so that a
# failure can be replayed.
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=tests/scripts/script_check.sh
source "$here/script_check.sh"
[ $# -ge 2 ] || { sed -n 2,9p "$0"; exit 2; }
bin=$(cd "$1" && pwd)
work=$2
seed=${3:-$(( $(date +%s%N) % 32768 ))}
RANDOM=$seed
echo "seed $seed"
rm -rf "$work"
mkdir -p "$work"
cd "$work" || exit 1

# Small but real runs: a self-prior of 270 steps, a query fit of 300 steps, checkpoints every 25;
# resolution 64 so that the grid stage (its first line comes before any work) outlasts the kill delay.
recon=("$bin/pcp_reconstruct" --preset fast --builtin-points 5000 --threads 1 --precision fp32 --steps 300
       --prior-epochs 10 --width 32 --resolution 64 --checkpoint-every 25 --progress-every 5)
train=("$bin/pcp_train" --preset fast --threads 1 --precision fp32 --width 32 --depth 2 --condition 32
       --grid 2 --steps 1600 --checkpoint-every 20 --progress-every 5)

# kill_in STAGE_REGEX LOG COMMAND...: starts COMMAND (output to LOG), waits until LOG shows a
# line matching STAGE_REGEX, sleeps a random 0-400 ms, sends SIGKILL. Returns 0 when the process
# died of the SIGKILL, 1 when it ended before (finished or failed).
kill_in() {
    local stage=$1 log=$2
    shift 2
    "$@" >"$log" 2>&1 &
    local pid=$!
    while ! grep -qE "$stage" "$log" 2>/dev/null; do
        if ! kill -0 "$pid" 2>/dev/null; then wait "$pid"; return 1; fi
        sleep 0.01
    done
    local ms=$(( RANDOM % 400 ))
    sleep "$(printf '0.%03d' "$ms")"
    kill -KILL "$pid" 2>/dev/null
    wait "$pid"
    local status=$?
    if [ "$status" -eq 137 ]; then
        echo "killed in '$stage' after $ms ms; last line: $(grep -v '^|' "$log" | tail -1)"
        return 0
    fi
    return 1
}

# --- pcp_reconstruct: reference, then one run killed in each stage in turn ---------------------
check "uninterrupted reconstruction" "${recon[@]}" -o ref.ply >ref.log 2>&1
stages=('^prior +[0-9]+%' '^query-net +[0-9]+%' '^sdf-grid')
for i in 0 1 2; do
    killed=0
    for attempt in 1 2 3 4 5; do
        if kill_in "${stages[$i]}" "kill$i.log" "${recon[@]}" -o out.ply --resume; then killed=1; break; fi
        # It ended before the kill (the random delay outlasted the stage): start this stage's
        # attempt again from scratch.
        echo "attempt $attempt: the run ended before the kill; retrying from scratch"
        rm -f out.ply out.ply.ckpt*
    done
    check "reconstruction killed in stage $i ('${stages[$i]}')" test "$killed" -eq 1
    check "no mesh after the kill in stage $i" test ! -e out.ply
done
ls -a >files_after_kills.txt
check "the query-network checkpoint exists after the kills" test -s out.ply.ckpt

# A damaged checkpoint is refused, names the file, and writes nothing.
cp out.ply.ckpt good.ckpt
head -c 100 good.ckpt >out.ply.ckpt
"${recon[@]}" -o out.ply --resume >truncated.log 2>&1
check "truncated checkpoint: non-zero exit" test $? -ne 0
check "truncated checkpoint: the error names the file" contains truncated.log "out.ply.ckpt: truncated network file"
check "truncated checkpoint: one line on stderr" test "$(grep -c 'error' truncated.log)" -eq 1
check "truncated checkpoint: no mesh" test ! -e out.ply
cp good.ckpt out.ply.ckpt
size=$(stat -c %s good.ckpt)
printf '\xff\xfe' | dd of=out.ply.ckpt bs=1 seek=$(( size / 2 )) conv=notrunc status=none
"${recon[@]}" -o out.ply --resume >corrupt.log 2>&1
check "corrupted checkpoint: non-zero exit" test $? -ne 0
check "corrupted checkpoint: the error names the file" contains corrupt.log "out.ply.ckpt: corrupt network file: checksum mismatch"
check "corrupted checkpoint: no mesh" test ! -e out.ply
cp good.ckpt out.ply.ckpt

check "resumed reconstruction finishes" "${recon[@]}" -o out.ply --resume >resume.log 2>&1
check "resumed mesh is byte-identical to the uninterrupted one" cmp ref.ply out.ply
check "no checkpoint left after the finished run" test -z "$(ls out.ply.ckpt* 2>/dev/null)"

# --- pcp_train: reference, then killed twice during training, resumed ---------------------------
"$bin/pcp_reconstruct" --builtin-points 3000 --preset fast --steps 1 --prior-epochs 1 --width 16 --resolution 16 \
    --threads 1 -q -o unused.ply --normals cloud.ply >/dev/null 2>&1
check "training cloud written" test -s cloud.ply
check "uninterrupted training" "${train[@]}" cloud.ply -o ref.pcpm >train_ref.log 2>&1
for k in 1 2; do
    killed=0
    for attempt in 1 2 3 4 5; do
        if kill_in '^prior +[0-9]+%' "train_kill$k.log" "${train[@]}" cloud.ply -o out.pcpm --resume; then killed=1; break; fi
        echo "attempt $attempt: training ended before the kill; retrying"
        rm -f out.pcpm out.pcpm.ckpt
    done
    check "training killed ($k)" test "$killed" -eq 1
    # The kill may land after the finished prior file was written and before the process exited:
    # then the file is whole (written in one rename), never a part of one.
    check "no prior file, or a whole one, after kill $k" eval 'test ! -e out.pcpm || cmp -s ref.pcpm out.pcpm'
    rm -f out.pcpm
done
check "resumed training finishes" "${train[@]}" cloud.ply -o out.pcpm --resume >train_resume.log 2>&1
check "resumed prior file is byte-identical to the uninterrupted one" cmp ref.pcpm out.pcpm

exit "$failed"
