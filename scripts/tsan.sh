#!/usr/bin/env bash
# Builds the engine's concurrent parts' tests with ThreadSanitizer into
# build-tsan/ and runs them: the executor and parallel_for (test_common),
# the block cache, sources, and pyramids built from many threads
# (test_terrain), clip-maps read while their loader thread publishes, and
# sessions with asynchronous loading (test_clipmap). Suppressions: tests/tsan.supp, each for a Debian library
# built without TSan. Extra arguments go to every test binary (e.g.
# --gtest_filter=BlockCache.*).
#
# The daemon's tests are not run here: Debian's gRPC is not instrumented, so
# every hand-off between its threads and the callbacks it runs reads as a
# race (239 reports over test_server_units), and a suppression broad enough
# to silence them would hide races in our reactors too.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

build_dir="${HORIZON_TSAN_BUILD_DIR:-build-tsan}"
binaries=(test_common test_terrain test_clipmap)
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DHORIZON_TSAN=ON \
  -DHORIZON_BUILD_BENCH=OFF >/dev/null
cmake --build "$build_dir" -j "$(nproc)" --target "${binaries[@]}"
export TSAN_OPTIONS="suppressions=$PWD/tests/tsan.supp halt_on_error=1 second_deadlock_stack=1"
for binary in "${binaries[@]}"; do
  echo "tsan: $binary"
  "$build_dir/tests/$binary" --gtest_brief=1 "$@"
done
echo "tsan: ${#binaries[@]} test binaries, no data race"
