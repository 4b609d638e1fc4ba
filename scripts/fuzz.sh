#!/usr/bin/env bash
# Builds the fuzz targets (tests/fuzz) with clang, libFuzzer, AddressSanitizer
# and UndefinedBehaviorSanitizer into build-fuzz/, and runs each for a
# bounded time from a copy of its seed corpus.
#
#   scripts/fuzz.sh                 every target, FUZZ_SECONDS each (default 60)
#   FUZZ_SECONDS=20 scripts/fuzz.sh raster config
#
# A crash, leak, timeout (> 10 s on one input) or out-of-memory (> 4 GiB)
# stops that target; its input is kept in build-fuzz/crashes/<target>/ and
# the script exits 1 naming it. To keep it as a regression test, copy it to
# tests/fuzz/corpus/<target>/ with a name saying what it found (the ordinary
# build's ctest replays every file there). New inputs that reached new code
# stay in build-fuzz/corpus/<target>/; the repository's seeds are not
# modified.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
source scripts/compiler_cache.sh

seconds="${FUZZ_SECONDS:-60}"
build_dir="${HORIZON_FUZZ_BUILD_DIR:-build-fuzz}"
targets=("$@")
((${#targets[@]})) || targets=(raster config requests mesh parse_guard)

CXX=clang++-14 cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" \
  -DHORIZON_FUZZ=ON -DHORIZON_SANITIZE=ON -DHORIZON_BUILD_TESTS=OFF -DHORIZON_BUILD_BENCH=OFF >/dev/null
cmake --build "$build_dir" -j "$(nproc)" --target "${targets[@]/#/fuzz_}"

failed=()
for target in "${targets[@]}"; do
  corpus="$build_dir/corpus/$target"
  crashes="$build_dir/crashes/$target"
  mkdir -p "$corpus" "$crashes"
  cp -n tests/fuzz/corpus/"$target"/* "$corpus"/ 2>/dev/null || true
  echo "fuzz: $target for ${seconds} s"
  # RSS is bounded at 4 GiB (fuzz_raster reads under a 64 MiB block limit, so a
  # header's claims cannot reach it), with ASan's quarantine of freed memory kept
  # small so that large honest blocks do not pile up. intercept_tls_get_addr=0
  # for the reason scripts/asan.sh gives (clang 14's runtime has the same flaw).
  if ! UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
      ASAN_OPTIONS=detect_leaks=1:intercept_tls_get_addr=0:quarantine_size_mb=64 \
      "$build_dir/tests/fuzz/fuzz_$target" -max_total_time="$seconds" -timeout=60 -rss_limit_mb=4096 \
      -max_len=65536 -print_final_stats=1 -artifact_prefix="$crashes/" "$corpus" >"$build_dir/fuzz_$target.log" 2>&1; then
    tail -40 "$build_dir/fuzz_$target.log" >&2
    failed+=("$target")
  else
    grep -E "stat::number_of_executed_units|cov:" "$build_dir/fuzz_$target.log" | tail -2
  fi
done
if ((${#failed[@]})); then
  echo "fuzz: failed: ${failed[*]} (inputs in $build_dir/crashes/)" >&2
  exit 1
fi
echo "fuzz: ${#targets[@]} targets, ${seconds} s each, no failure"
