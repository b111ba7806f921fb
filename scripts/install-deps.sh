#!/usr/bin/env bash
# Installs libpcp's build and test dependencies from Debian packages. Idempotent: installs only
# what is missing, and runs apt-get update only when something is. Run as root (or with sudo).
set -euo pipefail
packages=(build-essential cmake ninja-build pkg-config
          libeigen3-dev libcgal-dev libnanoflann-dev catch2 libcxxopts-dev time libpng-dev
          libopenblas-openmp-dev   # OpenBLAS: nn::gemm's default fp32 back end (PCP_BLAS=AUTO)
          libdnnl-dev              # oneDNN: the bf16 products of --precision bf16/auto (PCP_DNNL=AUTO)
          python3-dev pybind11-dev python3-numpy python3-pytest  # the Python module (python/) and its tests
          clang-14 libclang-rt-14-dev libomp-14-dev)  # libFuzzer targets of the readers (tests/fuzz/)
# With --bench also Open3D (about 550 MB of packages): the screened-Poisson baseline of the
# benchmarks (bench/poisson_open3d.cpp, built when found); neither the tools nor the tests need it.
for arg in "$@"; do
  case $arg in
    --bench) packages+=(libopen3d-dev) ;;
    *) echo "install-deps: unknown option $arg (known: --bench)" >&2; exit 2 ;;
  esac
done
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "install-deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
