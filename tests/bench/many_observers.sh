#!/usr/bin/env bash
# Many observers at once against gdal_viewshed once per observer, in one
# run, on this machine (docs/benchmarks.md, "Many observers").
#
#   tests/bench/many_observers.sh DEM [OBSERVERS] [REACH_M] [GDAL_RUNS]
#
# DEM in a metric CRS (gdal_viewshed's reach is in the DEM's units).
# OBSERVERS (default 1000) random observers on valid ground (fixed seed,
# 10 m above it), each seeing REACH_M ground metres (default 10000), target
# on the ground, curvature 0.85714. Prints:
#   - `horizon viewshed --observers` (fast, and exact = R3's answers) as a
#     whole process: wall time and peak RSS (/usr/bin/time);
#   - gdal_viewshed run once per observer for the first GDAL_RUNS observers
#     (default: all), then its rasters summed into a count GeoTIFF (numpy
#     through GDAL's Python bindings, one raster at a time, as a GIS user
#     would script it), each part timed and scaled to all observers;
#   - fast's count against exact's, and (when the peer ran for every
#     observer) the peer's against exact's: cells whose count differs, the
#     mean absolute difference, and the cells seen by some observer in one
#     answer and by none in the other.
# Needs build/ (scripts/build.sh) and gdal-bin (with python3-gdal, numpy).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."

if (($# < 1)); then
  sed -n '2,18p' "$0" >&2
  exit 2
fi
dem=$(realpath "$1")
n=${2:-1000}
reach=${3:-10000}
gdal_runs=${4:-$n}
horizon=build/client_cli/horizon
for tool in "$horizon" gdal_viewshed gdallocationinfo gdal_translate /usr/bin/time /usr/bin/python3; do
  command -v "$tool" >/dev/null || { echo "many_observers: '$tool' not found" >&2; exit 1; }
done
/usr/bin/python3 -c 'import numpy; from osgeo import gdal' 2>/dev/null ||
  { echo "many_observers: python3-gdal and numpy are needed to sum the peer's rasters" >&2; exit 1; }
# gdal_viewshed takes -md in the DEM's units: on a geographic DEM 10 000
# would be degrees, the whole raster, and the peer would do far more work.
if /usr/bin/python3 -c 'import sys; from osgeo import gdal, osr
s = osr.SpatialReference(gdal.Open(sys.argv[1]).GetProjection()); sys.exit(0 if s.IsGeographic() else 1)' "$1"; then
  echo "many_observers: $1 is in degrees; reproject it to metres first (gdalwarp -t_srs EPSG:326NN -tr 90 90)" >&2
  exit 1
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

echo "machine: $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(grep -o -m1 -w 'avx512f' /proc/cpuinfo || echo 'no avx512f'), $(date -u '+%F %H:%M') UTC"
echo "dem: $dem; $n observers, reach $reach m"

# Random points inside the DEM (a 2 % margin), kept where the four cells
# around each (its bilinear ground) hold data.
read -r ulx uly dx dy w h < <(gdalinfo "$dem" | awk -F'[(), ]+' '
  /^Origin/ {ox = $3; oy = $4} /^Pixel Size/ {px = $4; py = $5} /^Size is/ {sw = $3; sh = $4}
  END {print ox, oy, px, py, sw, sh}')
awk -v n=$((n * 3)) -v w="$w" -v h="$h" 'BEGIN {
  srand(20261204)
  for (i = 0; i < n; i++) {
    c = 0.02 * w + rand() * 0.96 * w; r = 0.02 * h + rand() * 0.96 * h
    printf "%.4f %.4f\n", c, r
  }
}' >"$work/candidates.txt"
awk '{c = int($1); r = int($2); print c, r; print c + 1, r; print c, r + 1; print c + 1, r + 1}' \
  "$work/candidates.txt" | gdallocationinfo -valonly "$dem" >"$work/values.txt"
awk 'NR == FNR {v[NR] = $1; next}
  {ok = 1; for (k = 0; k < 4; k++) {x = v[4 * (FNR - 1) + k + 1]; if (x == "" || x == "nan" || x + 0 < -1000) ok = 0}
   if (ok) print}' "$work/values.txt" "$work/candidates.txt" |
  awk -v n="$n" -v ulx="$ulx" -v uly="$uly" -v dx="$dx" -v dy="$dy" \
    'c < n {printf "%.9f,%.9f\n", ulx + ($1 + 0.5) * dx, uly + ($2 + 0.5) * dy; c++}' >"$work/observers.csv"
got=$(wc -l <"$work/observers.csv")
((got == n)) || { echo "many_observers: only $got observers on ground" >&2; exit 1; }

run_horizon() { # algorithm -> "seconds peak_kib"
  /usr/bin/time -f '%e %M' -o "$work/time.txt" "$horizon" viewshed "$dem" --observers "$work/observers.csv" \
    --height 10 --max-distance "$reach" --algorithm "$1" -o "$work/count_$1.tif" --json >"$work/$1.json"
  cat "$work/time.txt"
}
read -r fast_s fast_kib < <(run_horizon fast)
read -r exact_s exact_kib < <(run_horizon exact)
work_cells=$(grep -o '"work_cells": [0-9]*' "$work/fast.json" | grep -o '[0-9]*$')
compute_fast=$(grep -o '"compute_seconds": [0-9.e-]*' "$work/fast.json" | grep -o '[0-9.e-]*$')
compute_exact=$(grep -o '"compute_seconds": [0-9.e-]*' "$work/exact.json" | grep -o '[0-9.e-]*$')
echo "horizon fast:  process ${fast_s} s (compute ${compute_fast} s), peak RSS $((fast_kib / 1024)) MiB, work ${work_cells} cells"
echo "horizon exact: process ${exact_s} s (compute ${compute_exact} s), peak RSS $((exact_kib / 1024)) MiB"

# The peer, one process per observer (eye 10 m, the same reach and
# curvature; visible 255, hidden and out of reach 0), then the sum.
t0=$(date +%s.%N)
i=0
head -n "$gdal_runs" "$work/observers.csv" | while IFS=, read -r x y; do
  gdal_viewshed -q -ox "$x" -oy "$y" -oz 10 -md "$reach" -cc 0.85714 "$dem" "$work/gdal_$i.tif" >/dev/null 2>&1
  i=$((i + 1))
done
t1=$(date +%s.%N)
/usr/bin/python3 - "$work" "$gdal_runs" "$dem" <<'PY'
import sys
import numpy as np
from osgeo import gdal
work, runs, dem = sys.argv[1], int(sys.argv[2]), gdal.Open(sys.argv[3])
# Each raster is clamped to its observer's reach: placed in the DEM's grid.
t = dem.GetGeoTransform()
count = np.zeros((dem.RasterYSize, dem.RasterXSize), np.uint32)
for i in range(runs):
    one = gdal.Open(f"{work}/gdal_{i}.tif")
    g = one.GetGeoTransform()
    c0, r0 = round((g[0] - t[0]) / t[1]), round((g[3] - t[3]) / t[5])
    count[r0:r0 + one.RasterYSize, c0:c0 + one.RasterXSize] += one.ReadAsArray() == 255
out = gdal.GetDriverByName("GTiff").Create(f"{work}/count_gdal.tif", dem.RasterXSize, dem.RasterYSize, 1,
                                           gdal.GDT_UInt32, ["TILED=YES", "COMPRESS=DEFLATE"])
out.SetGeoTransform(t)
out.SetProjection(dem.GetProjection())
out.GetRasterBand(1).WriteArray(count)
out = None
PY
t2=$(date +%s.%N)
rm -f "$work"/gdal_*.tif
gdal_s=$(echo "$t1 - $t0" | bc)
sum_s=$(echo "$t2 - $t1" | bc)
gdal_all=$(echo "scale=2; ($gdal_s + $sum_s) * $n / $gdal_runs" | bc)
echo "gdal_viewshed x ${gdal_runs}: ${gdal_s} s, summing them ${sum_s} s; for ${n}: ${gdal_all} s"
echo "ratio: gdal_viewshed per observer and the sum / horizon fast = $(echo "scale=1; $gdal_all / $fast_s" | bc)x, / horizon exact = $(echo "scale=1; $gdal_all / $exact_s" | bc)x"

# Counts against exact's (R3's answers), cell by cell over exact's answered
# cells (the peer's raster covers the DEM: it is read over exact's window).
/usr/bin/python3 - "$work" "$((gdal_runs == n))" <<'PY'
import sys
import numpy as np
from osgeo import gdal
work, with_peer = sys.argv[1], sys.argv[2] == "1"
exact_ds = gdal.Open(f"{work}/count_exact.tif")
exact = exact_ds.ReadAsArray().astype(np.int64)
answered = exact != 4294967295
def compare(name, other):
    d = np.abs(other - exact)[answered]
    seen_a, seen_e = (other > 0)[answered], (exact > 0)[answered]
    cells, diff, any_diff, seen = answered.sum(), (d != 0).sum(), (seen_a != seen_e).sum(), seen_e.sum()
    print(f"{name} vs exact: {diff} of {cells} answered cells differ in count ({100 * diff / cells:.3f} %), "
          f"mean |diff| {d.mean():.4f} observers a cell; seen-by-any differs in {any_diff} cells "
          f"({100 * any_diff / seen:.3f} % of {seen} seen)")
fast = gdal.Open(f"{work}/count_fast.tif").ReadAsArray().astype(np.int64)
compare("fast", np.where(fast == 4294967295, 0, fast))
if with_peer:
    e, g = exact_ds.GetGeoTransform(), gdal.Open(f"{work}/count_gdal.tif")
    t = g.GetGeoTransform()
    c0, r0 = round((e[0] - t[0]) / t[1]), round((e[3] - t[3]) / t[5])
    peer = g.ReadAsArray(c0, r0, exact_ds.RasterXSize, exact_ds.RasterYSize).astype(np.int64)
    compare("gdal_viewshed", peer)
PY
