#!/usr/bin/env bash
# ThreadSanitizer over the engine's and the daemon's concurrent parts, built
# into build-tsan/.
#
# 1. Test binaries built with TSan: the executor and parallel_for
#    (test_common), the block cache, sources and pyramids built from many
#    threads (test_terrain), clip-maps read while their loader thread
#    publishes and sessions with asynchronous loading (test_clipmap), and the
#    daemon's units: the memory budget and admission, the deadline watch
#    racing calls' ends, config reloads (test_server_units; not ServerHealth,
#    whose test client is gRPC's own client code running in the test). Extra
#    arguments go to these binaries (e.g. --gtest_filter=BlockCache.*).
# 2. A TSan horizond under the daemon tests (the usual test_server from
#    HORIZON_BUILD_DIR, default build/, pointed at it by
#    HORIZON_TEST_HORIZOND): unary calls, a streamed viewshed with progress,
#    a client cancelling mid-stream, a clip-map session, a camera trace, and
#    32 clients at once (ServerConcurrency, 20 requests each here). The
#    daemons write their reports to files; any report fails the run.
#
# Suppressions: tests/tsan.supp (Debian libraries built without TSan, for
# both) and tests/tsan-grpc.supp (gRPC, abseil, protobuf and OpenSSL, for
# the daemon), each entry justified there. The reactors announce their own
# hand-offs through gRPC (server/src/handoff.hpp).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
source scripts/compiler_cache.sh

build_dir="${HORIZON_TSAN_BUILD_DIR:-build-tsan}"
tests_build_dir="${HORIZON_BUILD_DIR:-build}"
binaries=(test_common test_terrain test_clipmap test_server_units)
daemon_tests='ServerRpc.StreamedRaster*:ServerRpc.ProgressMessages*:ServerRpc.InvalidArgument*'
daemon_tests+=':ServerRpc.LineOfSightBatch*:ServerRpc.CullAnswers*:ServerRpc.ClientCancelling*'
daemon_tests+=':ServerSession.TheLatestPose*:ServerTrace.BoxAnswers*:ServerConcurrency.*'
daemon_tests+=':ServerMesh.CullMeshAnswers*:ServerMesh.AMeshFile*:ServerKept.*'

cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" -DHORIZON_TSAN=ON \
  -DHORIZON_BUILD_BENCH=OFF >/dev/null
cmake --build "$build_dir" -j "$(nproc)" --target "${binaries[@]}" horizond

export TSAN_OPTIONS="suppressions=$PWD/tests/tsan.supp halt_on_error=1 second_deadlock_stack=1"
for binary in "${binaries[@]}"; do
  echo "tsan: $binary"
  filter=()
  [[ "$binary" == test_server_units ]] && filter=(--gtest_filter=-ServerHealth.*)
  "$build_dir/tests/$binary" --gtest_brief=1 "${filter[@]}" "$@"
done

if [[ ! -x "$tests_build_dir/tests/test_server" ]]; then
  echo "tsan: $tests_build_dir/tests/test_server is not built (scripts/build.sh first)" >&2
  exit 1
fi
reports="$(mktemp -d)"
trap 'rm -rf "$reports"' EXIT
cat tests/tsan.supp tests/tsan-grpc.supp >"$reports/suppressions"
echo "tsan: horizond under test_server ($daemon_tests)"
# The daemons go on after a report (exitcode=0: the tests check their exit
# codes) and write every report under $reports; the tests' own pass or fail
# is what test_server returns. history_size=7 keeps both stacks of a report
# (32 clients overflow the default), so the suppressions can match them.
HORIZON_TEST_HORIZOND="$PWD/$build_dir/server/horizond" \
  TSAN_OPTIONS="suppressions=$reports/suppressions halt_on_error=0 exitcode=0 history_size=7 log_path=$reports/horizond" \
  "$tests_build_dir/tests/test_server" --gtest_brief=1 --gtest_filter="$daemon_tests"
if compgen -G "$reports/horizond*" >/dev/null; then
  cat "$reports"/horizond*
  echo "tsan: $(cat "$reports"/horizond* | grep -c 'WARNING: ThreadSanitizer') reports from horizond" >&2
  exit 1
fi
echo "tsan: ${#binaries[@]} test binaries and horizond under test_server, no data race"
