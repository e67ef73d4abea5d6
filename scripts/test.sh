#!/usr/bin/env bash
# Sets everything up (scripts/setup.sh) and runs every test with CTest, then
# the Python module's tests with pytest (python/tests, Debian's python3).
# Tests that need the shared scenes read HISFM_DATA_DIR (default
# ../shared/data next to the project).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export HISFM_DATA_DIR="${HISFM_DATA_DIR:-$(cd .. && pwd)/shared/data}"
if [ ! -d "$HISFM_DATA_DIR" ]; then
  echo "NOTE: HISFM_DATA_DIR=$HISFM_DATA_DIR does not exist: tests on the real scenes will be skipped."
fi
(cd build && ctest --output-on-failure -j2 --timeout 1800)
echo "==> Python module tests (pytest)"
HISFM_BINARY_DIR="$PWD/build" PYTHONPATH="$PWD/build/python" \
  /usr/bin/python3 -m pytest python/tests -q -p no:cacheprovider
