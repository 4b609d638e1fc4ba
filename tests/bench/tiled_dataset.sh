#!/usr/bin/env bash
# A dataset larger than the block cache, served by horizond (docs/benchmarks.md,
# "A dataset larger than memory").
#
#   tests/bench/tiled_dataset.sh FILE FOLDER X Y [CACHE_MB] [REQUESTS]
#
# FILE: one large raster; FOLDER: the same raster cut into tiles (e.g. with
# gdal_translate -srcwin), inside FILE's directory (the daemon's data_root).
# X, Y: an observer in their CRS. Starts one daemon
# (loopback, ephemeral ports) serving both as "file" and "tiles" with a
# CACHE_MB (default 128) block cache, then prints:
#   - the load: seconds to open and scan both (every block decoded once);
#   - per dataset, a 10 km viewshed at X,Y: cold (nothing of its window in the
#     cache: a second daemon is started for each), then warm (the same again),
#     milliseconds and bytes decoded, against the whole file's float bytes;
#   - 8 clients of REQUESTS (default 200) 10 km viewsheds at observers drawn
#     within 25 km of X,Y on "tiles": latency, and the cache's hit rate, peak
#     resident bytes against its budget, and the daemon's peak RSS.
# Needs build/ (scripts/build.sh) with tests/bench/load_horizond.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."

if (($# < 4)); then
  sed -n '2,18p' "$0" >&2
  exit 2
fi
file=$(realpath "$1")
folder=$(realpath "$2")
x=$3
y=$4
cache_mb=${5:-128}
requests=${6:-200}
horizond=build/server/horizond
horizon=build/client_cli/horizon
load=build/tests/bench/load_horizond
for tool in "$horizond" "$horizon" "$load" curl; do
  command -v "$tool" >/dev/null || { echo "tiled_dataset: '$tool' not found" >&2; exit 1; }
done

work=$(mktemp -d)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
root=$(dirname "$file")
file_rel=$(realpath --relative-to="$root" "$file")
folder_rel=$(realpath --relative-to="$root" "$folder")
[[ "$folder_rel" != ..* ]] || { echo "tiled_dataset: $folder is not inside $root" >&2; exit 2; }

# Starts a daemon serving DATASETS (JSON object body); sets $port, $mport, $pid.
start() {
  cat >"$work/horizond.json" <<JSON
{"listen": "127.0.0.1:0", "plaintext": true, "metrics_listen": "127.0.0.1:0", "data_root": "$root",
 "datasets": {$1}, "memory_budget_mb": $((cache_mb + 1024)), "block_cache_mb": $cache_mb,
 "worker_threads": 2, "engine_threads": 1, "limits": {"max_pending": 64}}
JSON
  : >"$work/log"
  "$horizond" --config "$work/horizond.json" 2>"$work/log" &
  pid=$!
  pids+=("$pid")
  for _ in $(seq 1200); do
    grep -q '"datasets_loaded"' "$work/log" && break
    kill -0 "$pid" 2>/dev/null || { echo "tiled_dataset: horizond did not start:" >&2; cat "$work/log" >&2; exit 1; }
    sleep 0.1
  done
  port=$(grep -o '"grpc_port":[0-9]*' "$work/log" | head -1 | cut -d: -f2)
  mport=$(grep -o '"metrics_port":[0-9]*' "$work/log" | head -1 | cut -d: -f2)
  load_seconds=$(grep '"datasets_loaded"' "$work/log" | grep -o '"seconds":[0-9.]*' | cut -d: -f2)
}
stop() {
  kill "$pid"
  wait "$pid" 2>/dev/null || true
}
metric() { curl -s "127.0.0.1:$mport/metrics" | awk -v k="$1" '$1 == k {print $2}'; }

whole_bytes=$(gdalinfo "$file" 2>/dev/null | awk '/^Size is/ {gsub(",", ""); print $3 * $4 * 4}')
echo "dataset: $(basename "$file") ($((whole_bytes / 4)) cells, $((whole_bytes >> 20)) MiB as float32) and $(ls "$folder" | wc -l) tiles; block cache $cache_mb MiB"

for name in file tiles; do
  # A daemon serving only this dataset: its load leaves the cache holding the
  # last blocks scanned; the viewshed's window is elsewhere, so its first
  # request decodes what it needs.
  if [[ $name == file ]]; then start "\"file\": \"$file_rel\""; else start "\"tiles\": \"$folder_rel\""; fi
  echo "$name: load (open + scan of every block) ${load_seconds} s"
  for round in cold warm1 warm2 warm3 warm4 warm5; do
    before=$(metric horizon_block_cache_decoded_bytes_total)
    t0=$(date +%s.%N)
    "$horizon" viewshed "$name" --server "127.0.0.1:$port" --observer "$x,$y" --max-distance 10000 \
      -o "$work/$name-$round.tif" >/dev/null
    t1=$(date +%s.%N)
    after=$(metric horizon_block_cache_decoded_bytes_total)
    decoded=$(python3 -c "print(int(float('$after') - float('$before')))")
    ms=$(python3 -c "print('%.0f' % ((float('$t1') - float('$t0')) * 1000))")
    if [[ $round == cold ]]; then
      python3 -c "print('$name: cold 10 km viewshed $ms ms (client, whole call), decoded %.1f MiB = %.2f %% of the file' % ($decoded / 2**20, 100 * $decoded / $whole_bytes))"
    else
      echo "$ms" >>"$work/$name-warm-ms"
      [[ $decoded == 0 ]] || echo "$name: a warm request decoded $decoded bytes!"
    fi
  done
  echo "$name: warm, median of 5: $(sort -n "$work/$name-warm-ms" | sed -n 3p) ms, decoded 0 bytes"
  # The server's own time, from its log lines (duration_ms), median of the warm five.
  echo "$name: warm, server time median: $(grep '"method":"ComputeViewshed"' "$work/log" | tail -5 |
    grep -o '"duration_ms":[0-9.]*' | cut -d: -f2 | sort -n | sed -n 3p) ms"
  cp "$work/$name-warm1.tif" "$work/$name-warm.tif"
  cmp -s "$work/$name-cold.tif" "$work/$name-warm.tif" || echo "$name: cold and warm outputs differ!"
  stop
done
cmp -s "$work/file-cold.tif" "$work/tiles-cold.tif" && echo "file and tiles: byte-identical viewsheds" ||
  echo "file and tiles: viewsheds DIFFER"

start "\"tiles\": \"$folder_rel\""
hits0=$(metric 'horizon_block_cache_requests_total{result="hit"}')
joins0=$(metric 'horizon_block_cache_requests_total{result="join"}')
miss0=$(metric 'horizon_block_cache_requests_total{result="miss"}')
rss_peak=0
( while kill -0 "$pid" 2>/dev/null; do
    awk '/VmHWM/ {print $2}' "/proc/$pid/status" >"$work/hwm" 2>/dev/null || true
    sleep 0.2
  done ) &
"$load" --server "127.0.0.1:$port" --dataset tiles --mode viewshed --x "$x" --y "$y" --spread 25000 \
  --clients 8 --requests "$requests" --max-distance 10000 --seed 7 || echo "load: some requests failed (above)"
hits=$(metric 'horizon_block_cache_requests_total{result="hit"}')
joins=$(metric 'horizon_block_cache_requests_total{result="join"}')
misses=$(metric 'horizon_block_cache_requests_total{result="miss"}')
peak=$(metric horizon_block_cache_peak_resident_bytes)
budget=$(metric horizon_block_cache_budget_bytes)
rss_peak=$(cat "$work/hwm" 2>/dev/null || echo 0)
python3 -c "
h, j, m = float('$hits') - float('$hits0'), float('$joins') - float('$joins0'), float('$misses') - float('$miss0')
print('load: blocks asked %d: hits %.1f %%, joins %.1f %%, misses %.1f %%' % (h + j + m, 100 * h / (h + j + m), 100 * j / (h + j + m), 100 * m / (h + j + m)))
print('load: cache peak resident %.1f MiB of a %.1f MiB budget; daemon peak RSS %.1f MiB' % (float('$peak') / 2**20, float('$budget') / 2**20, $rss_peak / 1024))"
stop
