#!/usr/bin/env bash
# Clip-map sessions through the daemon, loopback only: SESSIONS clients of
# `horizon session --server --rate RATE` at once, each with its own BOXES
# boxes (20 x 20 m, 0-30 m tall on the ground, within 10 km of the start,
# a seed a client) and the same flight: from (X, Y) east at 250 m/s, 100 m
# above the ground, POSES poses at RATE Hz. One horizond (memory budget
# 1024 MiB, 256 MiB block cache, worker threads = cores, sessions.max =
# SESSIONS); clip-maps of level size 512 and 512 rays, fast mode, as
# bench_session's table.
#
#   tests/bench/session_load.sh DEM.tif X Y [SESSIONS=8] [RATE=30] [POSES=300] [BOXES=10000]
#
# Prints, over every answered pose of every client: the daemon's time a pose
# (PoseAnswer.seconds) p50 / p99 / max, the poses answered, dropped (a newer
# pose came first: the daemon fell behind) and rejected, and the daemon's
# peak RSS. Exit 0 when every client ran to its end with no pose rejected.
# Needs GDAL's Python bindings (python3-gdal, installed with gdal-bin) for the
# boxes' ground. docs/benchmarks.md quotes a run.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
source tests/bench/horizond_lib.sh

if (($# < 3)); then
  sed -n '2,18p' "$0" >&2
  exit 2
fi
dem=$(realpath "$1")
x=$2
y=$3
sessions=${4:-8}
rate=${5:-30}
poses=${6:-300}
boxes=${7:-10000}
horizond=build/server/horizond
horizon=build/client_cli/horizon
py=/usr/bin/python3  # Debian's, which has GDAL's bindings (a pyenv python3 may shadow it)
work=$(mktemp -d)
pid=
trap '[[ -n "$pid" ]] && kill "$pid" 2>/dev/null; wait 2>/dev/null; rm -rf "$work"' EXIT

# The flight and each client's boxes.
"$py" - "$dem" "$x" "$y" "$sessions" "$rate" "$poses" "$boxes" "$work" <<'PY'
import math, random, sys
from osgeo import gdal
dem, x, y, sessions, rate, poses, boxes, work = sys.argv[1:]
x, y, rate = float(x), float(y), float(rate)
sessions, poses, boxes = int(sessions), int(poses), int(boxes)
ds = gdal.Open(dem)
band = ds.GetRasterBand(1)
nodata = band.GetNoDataValue()
t = ds.GetGeoTransform()
with open(f"{work}/flight.csv", "w") as f:
    for i in range(poses):
        f.write(f"{x + 250.0 * i / rate:.3f},{y:.3f},100,250,0\n")
for s in range(sessions):
    rng = random.Random(s + 1)
    with open(f"{work}/boxes{s}.csv", "w") as f:
        made = 0
        while made < boxes:
            r, a = 10000 * math.sqrt(rng.random()), rng.uniform(0, 2 * math.pi)
            bx, by = x + r * math.cos(a), y + r * math.sin(a)
            col, row = int((bx - t[0]) / t[1]), int((by - t[3]) / t[5])
            if col < 1 or row < 1 or col + 3 >= ds.RasterXSize or row + 3 >= ds.RasterYSize:
                continue
            ground = band.ReadAsArray(col - 1, row - 1, 4, 4)
            if nodata is not None and (ground == nodata).any():
                continue  # on a void: no ground to stand on
            z = float(ground.min())
            f.write(f"{bx - 10:.2f},{by - 10:.2f},{bx + 10:.2f},{by + 10:.2f},{z:.2f},{z + rng.uniform(0, 30):.2f}\n")
            made += 1
PY

cat >"$work/horizond.json" <<JSON
{"listen": "127.0.0.1:0", "plaintext": true, "data_root": "$(dirname "$dem")",
 "datasets": {"dem": "$(basename "$dem")"}, "memory_budget_mb": 1024, "block_cache_mb": 256,
 "worker_threads": 0, "engine_threads": 1, "gpu": {"contexts": 0}, "scratch_dir": "$work",
 "limits": {"max_pending": 64},
 "sessions": {"max": $sessions, "idle_ms": 60000, "max_boxes": 100000, "max_level_size": 2048,
              "level_size": 512, "subtile": 64}}
JSON
start_horizond "$horizond" "$work/horizond.json" "$work/log"
pid=$horizond_pid
echo "session_load: horizond pid $pid on port $horizond_port; $sessions sessions at $rate Hz, $poses poses," \
  "$boxes boxes each; $(nproc) cores"

clients=()
for ((s = 0; s < sessions; s++)); do
  "$horizon" session dem --server "127.0.0.1:$horizond_port" --path "$work/flight.csv" --boxes "$work/boxes$s.csv" \
    --level-size 512 --rays 512 --rate "$rate" --deadline 600 --session-id "load$s" --json >"$work/out$s.json" \
    2>"$work/err$s" &
  clients+=($!)
done
peak=0
while kill -0 "${clients[@]}" 2>/dev/null; do
  rss=$(awk '/^VmRSS:/ {print $2}' "/proc/$pid/status")
  ((rss > peak)) && peak=$rss
  sleep 0.2
done
status=0
for ((s = 0; s < sessions; s++)); do
  if ! wait "${clients[$s]}"; then
    echo "session_load: client $s failed: $(cat "$work/err$s")" >&2
    status=1
  fi
done
((status == 0)) || exit 1
"$py" - "$work" "$sessions" "$peak" <<'PY'
import json, sys
work, sessions, peak = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
seconds, sent, dropped, rejected = [], 0, 0, 0
for s in range(sessions):
    j = json.load(open(f"{work}/out{s}.json"))
    sent += j["poses_sent"]
    dropped += j["dropped"]
    rejected += j["rejected"]
    seconds += [p["seconds"] for p in j["poses"] if "seconds" in p]
seconds.sort()
pick = lambda q: seconds[min(len(seconds) - 1, int(q * len(seconds)))] * 1e3
print(f"session_load: {len(seconds)} of {sent} poses answered, {dropped} dropped, {rejected} rejected; "
      f"daemon time a pose p50 {pick(0.5):.2f} ms, p99 {pick(0.99):.2f} ms, max {pick(1.0):.2f} ms; "
      f"peak RSS {peak / 1024:.0f} MiB")
sys.exit(1 if rejected else 0)
PY
