#!/usr/bin/env bash
# A camera path over a DEM, traced frame by frame at several frame sizes,
# on the CPU and on the GL context EGL gives (llvmpipe without a GPU), in
# one run (docs/benchmarks.md, "Camera traces").
#
#   tests/bench/trace_path.sh DEM [FRAMES] [SIZES] [BACKENDS]
#
# The path: FRAMES poses (default 60) flying from 5 % to 45 % of the way up
# from the DEM's south edge along its middle, 200 m above the ground (an
# absolute altitude: over a void, 200 m above the last ground seen),
# looking north with the yaw swinging between -60 and +60 degrees (so
# frames change sub-frusta) and the pitch between -2 and -12; 60 degree
# pinhole. SIZES (default "512x512 1024x1024 1920x1080"), BACKENDS
# (default "cpu gpu"). Prints a Markdown table: per size and backend the
# trace's ms per frame (the trace alone, from `horizon trace --path
# --json`): the first frame (a GL context compiles its programs then), and
# min, median and max over the others with the slowest over the fastest.
# Needs build/ (scripts/build.sh), gdalinfo and gdallocationinfo.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."

if (($# < 1)); then
  sed -n '2,16p' "$0" >&2
  exit 2
fi
dem=$(realpath "$1")
frames=${2:-60}
sizes=${3:-512x512 1024x1024 1920x1080}
backends=${4:-cpu gpu}
horizon=build/client_cli/horizon
for tool in "$horizon" gdalinfo gdallocationinfo python3; do
  command -v "$tool" >/dev/null || { echo "trace_path: '$tool' not found" >&2; exit 1; }
done
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

gdalinfo -json "$dem" >"$work/info.json"
python3 - "$work/info.json" "$frames" "$dem" >"$work/path.csv" <<'PY'
import json, math, subprocess, sys
info = json.load(open(sys.argv[1]))
frames, dem = int(sys.argv[2]), sys.argv[3]
x0, dx, _, y0, _, dy = info["geoTransform"]
w, h = info["size"]
nodata = info["bands"][0].get("noDataValue")
print("x,y,altitude,yaw,pitch")
ground = None
for i in range(frames):
    f = i / max(frames - 1, 1)
    x = x0 + dx * w * 0.5
    y = y0 + dy * h * (0.95 - 0.40 * f)
    out = subprocess.run(["gdallocationinfo", "-valonly", "-geoloc", dem, f"{x}", f"{y}"],
                         capture_output=True, text=True, check=True).stdout.strip()
    value = float(out) if out else None
    if value is not None and value == value and (nodata is None or value != nodata):
        ground = value
    if ground is None:
        ground = 0.0
    yaw = 60.0 * math.sin(2.0 * math.pi * f)
    pitch = -7.0 + 5.0 * math.cos(2.0 * math.pi * f)
    print(f"{x:.3f},{y:.3f},{ground + 200.0:.2f},{yaw:.3f},{pitch:.3f}")
PY

echo "| frame | backend | first frame ms | then: min | median | max | slowest / fastest |"
echo "|---|---|---:|---:|---:|---:|---:|"
for size in $sizes; do
  for backend in $backends; do
    "$horizon" trace "$dem" --path "$work/path.csv" --altitude-path --size "$size" --backend "$backend" --json \
      >"$work/out.json" 2>"$work/err.txt" || { cat "$work/err.txt" >&2; exit 1; }
    python3 - "$work/out.json" "$size" "$backend" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
ms = [f["trace_ms"] for f in j["per_frame"]]
rest = sorted(ms[1:]) or ms
print(f"| {sys.argv[2]} | {sys.argv[3]} | {ms[0]:.2f} | {rest[0]:.2f} | {rest[len(rest) // 2]:.2f} | {rest[-1]:.2f} | "
      f"{rest[-1] / rest[0]:.2f} |")
PY
  done
done
