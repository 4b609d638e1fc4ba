#!/usr/bin/env bash
# Flood: many clients each sending the largest CullBoxes call at once to one
# horizond with a small memory budget, loopback only, for a bounded time.
# Prints the load generator's counts and the daemon's RSS at start, at its
# peak and idle after the flood (the heap is trimmed once idle).
#
#   tests/bench/flood.sh DEM.tif X Y [BUDGET_MB=192] [CLIENTS=64] [BOXES=100000] [SECONDS=20] [SCENE_RADIUS=1500]
#   RECEIVE_MB=48 tests/bench/flood.sh ...   sets receive_buffer_mb (default: the daemon's, budget/8)
#
# Boxes lie within SCENE_RADIUS metres of X,Y (the DEM must cover it).
# docs/benchmarks.md quotes a run.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
source tests/bench/horizond_lib.sh

if (($# < 3)); then
  sed -n '2,10p' "$0" >&2
  exit 2
fi
dem=$(realpath "$1")
x=$2
y=$3
budget=${4:-192}
clients=${5:-64}
boxes=${6:-100000}
seconds=${7:-20}
radius=${8:-1500}
work=$(mktemp -d)
pid=
trap '[[ -n "$pid" ]] && kill "$pid" 2>/dev/null; wait 2>/dev/null; rm -rf "$work"' EXIT
receive=
[[ -n "${RECEIVE_MB:-}" ]] && receive=" \"receive_buffer_mb\": $RECEIVE_MB,"
cat >"$work/flood.json" <<JSON
{"listen": "127.0.0.1:0", "plaintext": true, "data_root": "$(dirname "$dem")",
 "datasets": {"dem": "$(basename "$dem")"}, "memory_budget_mb": $budget, "block_cache_mb": 32,$receive
 "worker_threads": 2, "engine_threads": 1, "gpu": {"contexts": 0}, "limits": {"max_pending": 64},
 "scratch_dir": "$work"}
JSON
start_horizond build/server/horizond "$work/flood.json" "$work/log"
pid=$horizond_pid
status() { awk -v k="$1" '$1 == k {print $2}' "/proc/$pid/status"; }
start=$(status VmRSS:)
build/tests/bench/load_horizond --server "127.0.0.1:$horizond_port" --dataset dem --mode cull --x "$x" --y "$y" \
  --clients "$clients" --seconds "$seconds" --boxes "$boxes" --scene-radius "$radius" --max-distance "$radius" || true
sleep 1  # idle: the trim runs 100 ms after the last call
echo "flood: budget $budget MB, $clients clients x $boxes boxes; RSS at start $((start / 1024)) MB," \
  "peak $(($(status VmHWM:) / 1024)) MB, idle after $(($(status VmRSS:) / 1024)) MB"
