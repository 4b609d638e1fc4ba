#!/usr/bin/env bash
# Builds the engine's and the daemon's in-process unit tests with
# AddressSanitizer and UndefinedBehaviorSanitizer into build-asan/ and runs
# them: test_common, test_terrain, test_visibility, test_clipmap, test_mesh
# (the engine; test_mesh reads mesh files) and test_server_units (config, budget figures, health, deadlines,
# paths). Any report fails the run (UBSan does not recover). The daemon's
# process-level tests (test_server: a real horizond per test) are left to
# the ordinary build: under ASan their RSS checks mean nothing and their
# timing-bound cases would need looser bounds. Extra arguments go to every
# test binary (e.g. --gtest_filter=Grid*).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
source scripts/compiler_cache.sh

build_dir="${HORIZON_ASAN_BUILD_DIR:-build-asan}"
binaries=(test_common test_terrain test_visibility test_clipmap test_mesh test_server_units)
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" -DHORIZON_SANITIZE=ON \
  -DHORIZON_BUILD_BENCH=OFF >/dev/null
cmake --build "$build_dir" -j "$(nproc)" --target "${binaries[@]}"
# Leak checks on, with no suppression: nothing these tests load (Mesa's
# llvmpipe for the EGL tests included) leaks by LeakSanitizer's count.
# intercept_tls_get_addr=0: the runtime of GCC 12 (and LLVM before 17) takes
# a dynamic TLS block that happens to start 16 bytes into a page for a
# pre-2.25 glibc header and reads the two words before it as the block's
# address and size. The leak check's tracer then reads wild memory and dies
# ("Tracer caught signal 11 ... LeakSanitizer has encountered a fatal error")
# after every test has passed, at random, which failed a CI run on
# test_clipmap. Off, the check does not scan dlopen'ed libraries' dynamic
# TLS (Mesa's), which holds no block of ours.
export ASAN_OPTIONS="detect_leaks=1:intercept_tls_get_addr=0:strict_string_checks=1:detect_stack_use_after_return=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
for binary in "${binaries[@]}"; do
  echo "asan: $binary"
  "$build_dir/tests/$binary" --gtest_brief=1 "$@"
done
echo "asan: ${#binaries[@]} test binaries, no report"
