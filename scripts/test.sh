#!/usr/bin/env bash
# Installs what is needed, builds with warnings as errors, runs the whole
# test suite, prints the whole-process speed against gdal_viewshed on the
# bundled DEMs (tests/bench/peer_speed.sh --short: printed, never a failure
# on a slow run; HORIZON_PEER_SPEED=0 skips it), then the engine's
# concurrency tests, the daemon's unit tests and a daemon under
# ThreadSanitizer (scripts/tsan.sh; HORIZON_TSAN=0 skips it), then the
# engine's and the daemon's unit tests under AddressSanitizer and UBSan
# (scripts/asan.sh; HORIZON_ASAN=0 skips it), then fuzzes every target for
# HORIZON_FUZZ_SECONDS (default 30; 0 skips it) in a
# clang/libFuzzer/ASan/UBSan build (scripts/fuzz.sh). Extra arguments go to
# ctest (e.g. -R Cli, -j 1); HORIZON_BUILD_DIR picks the build directory as
# in build.sh.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

scripts/setup.sh
HORIZON_WERROR=ON scripts/build.sh
# Tests run on every core unless the arguments say otherwise (-j N, a later
# one wins); the suite's servers take free ports and private directories.
ctest --test-dir "${HORIZON_BUILD_DIR:-build}" --output-on-failure -j "$(nproc)" "$@"
if [[ "${HORIZON_PEER_SPEED:-1}" != 0 ]]; then
  tests/bench/peer_speed.sh --short
fi
if [[ "${HORIZON_TSAN:-1}" != 0 ]]; then
  scripts/tsan.sh
fi
if [[ "${HORIZON_ASAN:-1}" != 0 ]]; then
  scripts/asan.sh
fi
fuzz_seconds="${HORIZON_FUZZ_SECONDS:-30}"
if ((fuzz_seconds > 0)); then
  FUZZ_SECONDS="$fuzz_seconds" scripts/fuzz.sh
fi
