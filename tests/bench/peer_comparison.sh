#!/usr/bin/env bash
# Horizon against gdal_viewshed and GRASS r.viewshed on one DEM and observer,
# in one run, on this machine (docs/benchmarks.md, "The 12 M-cell case").
#
#   tests/bench/peer_comparison.sh DEM X Y [REPEATS] [--no-r3]
#
# X, Y: the observer in the DEM's CRS (eye 2 m above ground, target on the
# ground, curvature 0.85714 = refraction 1/7, whole DEM). Prints one line per
# measurement:
#   - whole process, interleaved REPEATS times (default 5), median: gdal_viewshed
#     and `horizon viewshed` (fast, the default), both writing a GeoTIFF;
#   - engine compute time (`horizon viewshed --json`, stats.seconds) of fast,
#     conservative, exact (visible raster: decides visibility only), exact
#     (--output ohf: R3's whole OHF) and r3 (skipped with --no-r3; minutes);
#   - GRASS r.viewshed, the module alone (import and session start excluded);
#   - whether exact's and R3's visible rasters are byte-identical.
# Needs build/ (scripts/build.sh), gdal-bin and grass-core (scripts/setup.sh).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."

if (($# < 3)); then
  sed -n '2,17p' "$0" >&2
  exit 2
fi
dem=$(realpath "$1")
x=$2
y=$3
repeats=${4:-5}
with_r3=1
[[ "${5:-}" == "--no-r3" || "${4:-}" == "--no-r3" ]] && with_r3=0
[[ "$repeats" =~ ^[0-9]+$ ]] || repeats=5
horizon=build/client_cli/horizon
for tool in "$horizon" gdal_viewshed grass; do
  command -v "$tool" >/dev/null || { echo "peer_comparison: '$tool' not found" >&2; exit 1; }
done

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

median() { sort -n | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
seconds() { # command... -> wall seconds
  local t0 t1
  t0=$(date +%s.%N)
  "$@" >/dev/null 2>&1
  t1=$(date +%s.%N)
  echo "$t1 - $t0" | bc
}

echo "machine: $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(date -u +%F)"
echo "dem: $dem; observer $x,$y"

# 1. Whole processes, interleaved.
gdal_runs=()
horizon_runs=()
for ((i = 0; i < repeats; i++)); do
  gdal_runs+=("$(seconds gdal_viewshed -q -ox "$x" -oy "$y" -oz 2 -cc 0.85714 "$dem" "$work/gdal.tif")")
  horizon_runs+=("$(seconds "$horizon" viewshed "$dem" --observer "$x,$y" --height 2 -o "$work/hz.tif")")
done
echo "process gdal_viewshed: ${gdal_runs[*]} -> median $(printf '%s\n' "${gdal_runs[@]}" | median) s"
echo "process horizon (fast): ${horizon_runs[*]} -> median $(printf '%s\n' "${horizon_runs[@]}" | median) s"

# 2. Engine compute times.
compute() { # name, extra args...
  local name=$1
  shift
  "$horizon" viewshed "$dem" --observer "$x,$y" --height 2 -o "$work/$name.tif" --json "$@" >"$work/$name.json"
  python3 -c "import json, sys; d = json.load(open(sys.argv[1])); s = d['stats']
print(f\"compute {sys.argv[2]}: {s['seconds']:.3f} s, {s['cells_evaluated']} cells, {s['terrain_samples']} samples\")" \
    "$work/$name.json" "$name"
}
compute fast --algorithm fast
compute conservative --algorithm conservative
compute exact --algorithm exact
compute exact_ohf --algorithm exact --output ohf
if ((with_r3)); then
  compute r3 --algorithm r3
  if cmp -s "$work/exact.tif" "$work/r3.tif"; then echo "exact == r3: identical visible rasters"; else echo "exact != r3"; fi
fi

# 3. GRASS r.viewshed, module time only.
cat >"$work/grass.sh" <<EOF
set -e
r.in.gdal -o input=$dem output=dem --quiet --overwrite
g.region raster=dem
t0=\$(date +%s.%N)
r.viewshed -b -c -r refraction_coeff=0.14286 input=dem output=vs coordinates=$x,$y observer_elevation=2 \
  target_elevation=0 memory=2000 --quiet --overwrite
t1=\$(date +%s.%N)
echo "GRASS_SECONDS \$(echo "\$t1 - \$t0" | bc)"
EOF
grass_out=$(grass --tmp-location "$dem" --exec bash "$work/grass.sh" 2>&1 || true)
echo "module r.viewshed: $(echo "$grass_out" | awk '/^GRASS_SECONDS/ {print $2}') s"
