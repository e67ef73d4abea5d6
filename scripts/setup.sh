#!/usr/bin/env bash
# Installs HiSfM's dependencies from Debian 12 packages and builds it into
# build/: the `hisfm` command and the Python module `hisfm` (build/python,
# for Debian's /usr/bin/python3). Safe to run again: apt-get skips what is
# installed, cmake rebuilds only what changed.
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  build-essential cmake git pkg-config
  colmap
  libeigen3-dev libceres-dev libsqlite3-dev sqlite3
  libcli11-dev nlohmann-json3-dev libspdlog-dev libfmt-dev
  libboost-graph-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  # The Python module (build/python) and its tests.
  pybind11-dev python3-dev python3-numpy python3-pytest
  chromium
  # hisfm reconstruct --executor slurm and its tests (scripts/local_slurm.sh).
  slurm-wlm munge
  # scripts/sanitize.sh: ASan/UBSan build and libFuzzer targets.
  clang libclang-rt-14-dev llvm-14
)

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" \
    || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  echo "==> Installing: ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
    "${missing[@]}" > /tmp/hisfm-apt.log 2>&1 \
    || { tail -20 /tmp/hisfm-apt.log; exit 1; }
fi

echo "==> Building HiSfM"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build build -j"$(nproc)"
echo "==> Built build/hisfm and build/python (PYTHONPATH=build/python python3 -c 'import hisfm')"
