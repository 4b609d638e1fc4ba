#!/usr/bin/env bash
# Many observers at once against gdal_viewshed once per observer, in one
# run, on this machine (docs/benchmarks.md, "Many observers").
#
#   tests/bench/many_observers.sh DEM [OBSERVERS] [REACH_M] [GDAL_RUNS]
#
# OBSERVERS (default 1000) random observers on valid ground (fixed seed,
# 10 m above it), each seeing REACH_M ground metres (default 10000), target
# on the ground, curvature 0.85714. Prints:
#   - `horizon viewshed --observers` (fast, and exact = R3's answers) as a
#     whole process: wall time and peak RSS (/usr/bin/time);
#   - gdal_viewshed run once per observer for the first GDAL_RUNS observers
#     (default: all), wall time summed, and that sum scaled to all of them
#     (the rasters' sum is not done, so the peer's figure is a lower bound);
#   - fast's count against exact's: cells whose count differs, the mean
#     absolute difference, and the cells seen by some observer in one
#     answer and by none in the other.
# Needs build/ (scripts/build.sh) and gdal-bin.
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
for tool in "$horizon" gdal_viewshed gdallocationinfo gdal_translate /usr/bin/time; do
  command -v "$tool" >/dev/null || { echo "many_observers: '$tool' not found" >&2; exit 1; }
done
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

# The peer, one process per observer (eye 10 m, the same reach and curvature).
t0=$(date +%s.%N)
head -n "$gdal_runs" "$work/observers.csv" | while IFS=, read -r x y; do
  gdal_viewshed -q -ox "$x" -oy "$y" -oz 10 -md "$reach" -cc 0.85714 "$dem" "$work/gdal.tif" >/dev/null 2>&1
done
t1=$(date +%s.%N)
gdal_s=$(echo "$t1 - $t0" | bc)
gdal_all=$(echo "scale=2; $gdal_s * $n / $gdal_runs" | bc)
echo "gdal_viewshed x ${gdal_runs}: ${gdal_s} s; for ${n}: ${gdal_all} s (sum of rasters not included)"
echo "ratio: gdal_viewshed per observer / horizon fast = $(echo "scale=1; $gdal_all / $fast_s" | bc)x, / horizon exact = $(echo "scale=1; $gdal_all / $exact_s" | bc)x"

# fast against exact (R3's answers), cell by cell.
gdal_translate -q -of XYZ "$work/count_fast.tif" "$work/fast.xyz"
gdal_translate -q -of XYZ "$work/count_exact.tif" "$work/exact.xyz"
paste -d' ' "$work/fast.xyz" "$work/exact.xyz" | awk '
  $3 + 0 < 4.29e9 && $6 + 0 < 4.29e9 {  # nodata 4294967295 prints as a float
    cells++; d = $3 - $6; if (d != 0) {diff++; sum += (d < 0 ? -d : d)}
    if (($3 > 0) != ($6 > 0)) any++
    if ($6 > 0) seen++
  }
  END {printf "fast vs exact: %d of %d answered cells differ in count (%.3f %%), mean |diff| %.4f observers a cell; seen-by-any differs in %d cells (%.3f %% of %d seen)\n",
       diff, cells, 100 * diff / cells, sum / cells, any, 100 * any / seen, seen}'
