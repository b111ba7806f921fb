#!/usr/bin/env bash
# make_builtin_prior.sh: regenerates assets/builtin_prior.pcpm, the generic prior compiled into the
# library (pcp::builtin_prior, what pcp_reconstruct uses without --prior). It is trained by
# pcp_train on 48 generated shapes (pcp/train/training_shapes.hpp: CSG of boxes, cylinders, cones,
# ellipsoids, tori, capsules, thin plates and open shells with holes, blends and cuts; 10k-40k
# points; a third of them noisy) -- no third-party data. Deterministic: the same command on the
# same thread count writes the same bytes (2 threads: about 4 minutes on a 2-core AVX2 machine).
#
# Usage: scripts/make_builtin_prior.sh [OUTPUT]   (default: assets/builtin_prior.pcpm)
# Environment: BIN (default build/bin). Rebuild afterwards to embed the new file.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
BIN=${BIN:-$repo/build/bin}
out=${1:-$repo/assets/builtin_prior.pcpm}
OMP_NUM_THREADS=${OMP_NUM_THREADS:-2} "$BIN/pcp_train" --preset fast --shapes 48 --shapes-seed 1 --steps 20000 \
    --seed 1 --progress-every 1000 -o "$out"
