#!/usr/bin/env bash
# Configures and builds Horizon with Ninja into ./build (Release).
# Environment:
#   HORIZON_WERROR=ON     treat compiler warnings as errors (CI does)
#   HORIZON_SANITIZE=ON   AddressSanitizer + UndefinedBehaviorSanitizer build
#   HORIZON_BUILD_DIR     build directory (default: build)
#   HORIZON_BUILD_TYPE    CMake build type (default: Release)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
source scripts/compiler_cache.sh

build_dir="${HORIZON_BUILD_DIR:-build}"
cmake -S . -B "$build_dir" -G Ninja \
  -DCMAKE_BUILD_TYPE="${HORIZON_BUILD_TYPE:-Release}" \
  -DHORIZON_WERROR="${HORIZON_WERROR:-OFF}" \
  -DHORIZON_SANITIZE="${HORIZON_SANITIZE:-OFF}"
cmake --build "$build_dir" -j "$(nproc)"
