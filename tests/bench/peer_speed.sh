#!/usr/bin/env bash
# Whole-process speed of `horizon viewshed` against gdal_viewshed over many
# DEMs and observers, interleaved in one run on this machine, with the
# default's accuracy against R3 beside each line (docs/benchmarks.md, "Whole
# process against gdal_viewshed").
#
#   tests/bench/peer_speed.sh [--repeats N] [--observers N] [--isa SET,...] DEM...
#   tests/bench/peer_speed.sh --short      # CI: the bundled DEMs, printed only
#                                          # (AVX-512 and AVX2 kernels where the CPU has both)
#
# For each DEM the observers are `horizon bench`'s deterministic picks
# (summit, ridge, valley, edge, then random; default 3), eye 2 m above the
# ground, target on the ground, curvature 0.85714, the whole DEM. Each pair
# of processes (gdal_viewshed, then `horizon viewshed` with its defaults,
# both writing a GeoTIFF) runs --repeats times (default 5) in turn; a line
# gives both medians and gdal's over Horizon's (above 1: Horizon is faster).
# --isa avx512,avx2 times `horizon viewshed --isa SET` for each set named
# (scalar, avx2, avx512), each in its own column, all in the same interleaved
# loop: the AVX2 kernels' whole-process time on an AVX-512 machine. Without
# it, one column: the CPU's best. The last lines are the geometric means. The IoU is the default
# setting's against R3, from `horizon bench` (which runs R3 untimed: seconds
# on a 1201 x 1201 DEM, minutes on 12 M cells). Prints Markdown; never fails
# on a slow run, only when a tool is missing or a run fails.
#
# Needs build/ (scripts/build.sh; HORIZON_BUILD_DIR picks another) and
# gdal-bin (scripts/setup.sh).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."

repeats=5
observers=3
isas=()
short=0
dems=()
while (($#)); do
  case "$1" in
    --repeats) repeats=${2:-}; shift $(($# > 1 ? 2 : 1)) ;;
    --observers) observers=${2:-}; shift $(($# > 1 ? 2 : 1)) ;;
    --isa) IFS=, read -ra isas <<<"${2:-}"; shift $(($# > 1 ? 2 : 1)) ;;
    --short) short=1; repeats=3; observers=1; dems+=(data/dem/*.tif); shift ;;
    -h | --help) sed -n '2,22p' "$0"; exit 0 ;;
    -*) echo "peer_speed: unknown flag '$1' (see --help)" >&2; exit 2 ;;
    *) dems+=("$1"); shift ;;
  esac
done
[[ "$repeats" =~ ^[1-9][0-9]*$ ]] || { echo "peer_speed: --repeats: expected a whole number from 1, got '$repeats'" >&2; exit 2; }
[[ "$observers" =~ ^[1-9][0-9]*$ ]] || { echo "peer_speed: --observers: expected a whole number from 1, got '$observers'" >&2; exit 2; }
((${#dems[@]})) || { echo "peer_speed: no DEM given (see --help)" >&2; exit 2; }
for set in "${isas[@]}"; do
  [[ "$set" =~ ^(scalar|avx2|avx512)$ ]] || { echo "peer_speed: --isa: expected scalar, avx2 or avx512, got '$set'" >&2; exit 2; }
done
# The horizon columns: one per --isa set, or the CPU's best (""); the short
# form on an AVX-512 machine times the AVX2 kernels beside them.
if ((short)) && ((${#isas[@]} == 0)) && grep -qw avx512f /proc/cpuinfo; then isas=(avx512 avx2); fi
columns=("${isas[@]}")
((${#columns[@]})) || columns=("")
for dem in "${dems[@]}"; do
  [[ -f "$dem" ]] || { echo "peer_speed: '$dem': no such file" >&2; exit 2; }
done
horizon=${HORIZON_BUILD_DIR:-build}/client_cli/horizon
for tool in "$horizon" gdal_viewshed; do
  command -v "$tool" >/dev/null || { echo "peer_speed: '$tool' not found (scripts/build.sh, scripts/setup.sh)" >&2; exit 1; }
done

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

median() { sort -n | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
seconds() { # command... -> wall seconds; a failed run stops the script
  local t0 t1
  t0=$(date +%s.%N)
  "$@" >"$work/run.log" 2>&1 || { echo "peer_speed: failed: $*" >&2; cat "$work/run.log" >&2; exit 1; }
  t1=$(date +%s.%N)
  echo "$t1 - $t0" | bc
}

flags=$(grep -m1 '^flags' /proc/cpuinfo)
isa=scalar
[[ " $flags " == *" avx2 "* ]] && isa=AVX2
[[ " $flags " == *" avx512f "* ]] && isa="AVX-512 and AVX2"
echo "Machine: $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $isa;" \
  "$(gdalinfo --version 2>/dev/null | cut -d, -f1); $(date -u '+%F %H:%M') UTC; median of $repeats"
echo
header="| DEM | observer | cells | gdal_viewshed |"
rule="|---|---|---:|---:|"
for set in "${columns[@]}"; do
  label=${set:+horizon --isa $set}
  header+=" ${label:-horizon} | gdal / horizon |"
  rule+="---:|---:|"
done
echo "$header IoU vs R3 |"
echo "$rule---:|"

declare -a log_sum
for c in "${!columns[@]}"; do log_sum[c]=0; done
pairs=0
for dem in "${dems[@]}"; do
  name=$(basename "$dem")
  rm -rf "$work/bench"
  # The picks and the default's IoU against R3.
  "$horizon" bench "$dem" --observers "$observers" --algorithms fast --peers none --repeats 1 --warmup 0 \
    -o "$work/bench" >"$work/bench.log" 2>&1 || { cat "$work/bench.log" >&2; exit 1; }
  # observer, x, y, cells, iou of the default setting's rows
  python3 - "$work/bench/bench.csv" >"$work/picks" <<'EOF'
import csv, sys
with open(sys.argv[1]) as f:
    for row in csv.DictReader(f):
        if row["algorithm"] == "fast" and row["default"] == "1" and row["peer"] == "0":
            iou = f"{100 * float(row['iou']):.2f} %" if row["iou"] else "-"
            cells = int(row["width"]) * int(row["height"])
            print(row["observer"], row["x"], row["y"], cells, iou.replace(" ", "_"))
EOF
  while read -r observer x y cells iou; do
    gdal_runs=()
    declare -A horizon_runs=()
    for ((i = 0; i < repeats; i++)); do
      gdal_runs+=("$(seconds gdal_viewshed -q -ox "$x" -oy "$y" -oz 2 -cc 0.85714 "$dem" "$work/gdal.tif")")
      for c in "${!columns[@]}"; do
        set=${columns[c]}
        horizon_runs[$c]+="$(seconds "$horizon" viewshed "$dem" --observer "$x,$y" --height 2 ${set:+--isa "$set"} \
          -o "$work/hz.tif") "
        rm -f "$work/hz.tif"
      done
      rm -f "$work/gdal.tif"
    done
    g=$(printf '%s\n' "${gdal_runs[@]}" | median)
    line=$(printf '| %s | %s | %s | %.3f s |' "$name" "$observer" "$cells" "$g")
    for c in "${!columns[@]}"; do
      h=$(printf '%s\n' ${horizon_runs[$c]} | median)
      ratio=$(echo "scale=6; $g / $h" | bc)
      log_sum[c]=$(echo "scale=9; ${log_sum[c]} + l($ratio)" | bc -l)
      line+=$(printf ' %.3f s | %.2fx |' "$h" "$ratio")
    done
    unset horizon_runs
    pairs=$((pairs + 1))
    echo "$line ${iou//_/ } |"
  done <"$work/picks"
done
echo
for c in "${!columns[@]}"; do
  set=${columns[c]}
  printf 'Geometric mean of gdal / horizon%s over %d runs: %.2fx\n' "${set:+ --isa $set}" "$pairs" \
    "$(echo "scale=6; e(${log_sum[c]} / $pairs)" | bc -l)"
done
