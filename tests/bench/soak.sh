#!/usr/bin/env bash
# Soak: one horizond under mixed load (viewsheds, culling, sight lines) from
# many clients for a bounded time, loopback only. Samples the daemon's RSS
# every 10 s and reports it with the load generator's counts and latencies.
#
#   tests/bench/soak.sh DEM.tif X Y [CLIENTS=64] [SECONDS=600]
#
# Passes (exit 0) when the load saw no error other than refusals
# (RESOURCE_EXHAUSTED or UNAVAILABLE: admission doing its job) and the RSS,
# after the first minute's warm-up (first 10 % of the run when shorter), stays
# within 10 % of its median. docs/benchmarks.md quotes a run.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
source tests/bench/horizond_lib.sh

if (($# < 3)); then
  sed -n '2,12p' "$0" >&2
  exit 2
fi
dem=$(realpath "$1")
x=$2
y=$3
clients=${4:-64}
seconds=${5:-600}
horizond=build/server/horizond
load=build/tests/bench/load_horizond
work=$(mktemp -d)
pid=
trap '[[ -n "$pid" ]] && kill "$pid" 2>/dev/null; wait 2>/dev/null; rm -rf "$work"' EXIT
cat >"$work/soak.json" <<JSON
{"listen": "127.0.0.1:0", "plaintext": true, "data_root": "$(dirname "$dem")",
 "datasets": {"dem": "$(basename "$dem")"}, "memory_budget_mb": 1024, "worker_threads": 2,
 "engine_threads": 1, "gpu": {"contexts": 0}, "limits": {"max_pending": 64}, "scratch_dir": "$work"}
JSON
start_horizond "$horizond" "$work/soak.json" "$work/log"
pid=$horizond_pid
port=$horizond_port
rss() { awk '/^VmRSS:/ {print $2}' "/proc/$pid/status"; }
echo "soak: horizond pid $pid on port $port, $clients clients, ${seconds} s, RSS at start $(rss) KiB"

"$load" --server "127.0.0.1:$port" --dataset dem --mode mixed --x "$x" --y "$y" --clients "$clients" \
  --seconds "$seconds" --boxes 2000 --max-distance 10000 --scene-radius 3000 >"$work/load.out" 2>&1 &
load_pid=$!
: >"$work/rss"
while kill -0 "$load_pid" 2>/dev/null; do
  sleep 10
  kill -0 "$load_pid" 2>/dev/null && rss >>"$work/rss"
done
load_status=0
wait "$load_pid" || load_status=$?
cat "$work/load.out"
echo "soak: peak RSS $(awk '/^VmHWM:/ {print $2}' "/proc/$pid/status") KiB; after the load $(rss) KiB"
warm=$((seconds >= 600 ? 6 : (seconds / 100 > 0 ? seconds / 100 : 1)))
python3 - "$work/rss" "$warm" <<'PY'
import statistics, sys
samples = [int(l) for l in open(sys.argv[1]) if l.strip()]
steady = samples[int(sys.argv[2]):] or samples
median = statistics.median(steady)
lo, hi = min(steady), max(steady)
spread = max(hi - median, median - lo) / median
print("soak: RSS samples (KiB, every 10 s): " + " ".join(str(s) for s in samples))
print("soak: steady RSS median %d KiB, min %d, max %d: within %.1f %% of the median" % (median, lo, hi, 100 * spread))
sys.exit(0 if spread <= 0.10 else 3)
PY
rss_status=$?
((load_status == 0)) || { echo "soak: the load saw errors other than refusals" >&2; exit 1; }
((rss_status == 0)) || { echo "soak: RSS not flat within 10 %" >&2; exit 1; }
echo "soak: passed"
