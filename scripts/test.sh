#!/usr/bin/env bash
# Installs what is needed, builds with warnings as errors and runs the whole
# test suite. Extra arguments go to ctest (e.g. -R Cli, -j 2); HORIZON_BUILD_DIR
# picks the build directory as in build.sh.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

scripts/setup.sh
HORIZON_WERROR=ON scripts/build.sh
ctest --test-dir "${HORIZON_BUILD_DIR:-build}" --output-on-failure "$@"
