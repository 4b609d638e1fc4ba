#!/usr/bin/env bash
# Where one `horizon viewshed` process spends its time, phase by phase, on
# each kernel set, against gdal_viewshed's whole process in the same
# interleaved runs (docs/benchmarks.md, "Where the whole process goes").
#
#   tests/bench/process_phases.sh [--repeats N] [--isa SET,...] DEM X Y
#
# Each repeat runs gdal_viewshed, then `horizon viewshed DEM --observer X,Y
# --json [--isa SET]` for each set named (scalar, avx2, avx512; default: the
# CPU's best only), eye 2 m up, target on the ground, curvature 0.85714, the
# whole DEM, a GeoTIFF written. The phases are Horizon's own (--json
# "phases"); "start and exit" is the whole process's wall time minus the
# phases' span (total_seconds): loading the libraries, and freeing the
# memory at exit. Prints a Markdown table of medians (default 7 repeats).
# Needs build/ (HORIZON_BUILD_DIR picks another), gdal-bin and python3.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."

repeats=7
isas=()
args=()
while (($#)); do
  case "$1" in
    --repeats) repeats=${2:-}; shift $(($# > 1 ? 2 : 1)) ;;
    --isa) IFS=, read -ra isas <<<"${2:-}"; shift $(($# > 1 ? 2 : 1)) ;;
    -h | --help) sed -n '2,16p' "$0"; exit 0 ;;
    -[0-9.]*) args+=("$1"); shift ;;  # a negative coordinate
    -*) echo "process_phases: unknown flag '$1' (see --help)" >&2; exit 2 ;;
    *) args+=("$1"); shift ;;
  esac
done
((${#args[@]} == 3)) || { echo "process_phases: expected DEM X Y (see --help)" >&2; exit 2; }
[[ "$repeats" =~ ^[1-9][0-9]*$ ]] || { echo "process_phases: --repeats: expected a whole number from 1, got '$repeats'" >&2; exit 2; }
for set in "${isas[@]}"; do
  [[ "$set" =~ ^(scalar|avx2|avx512)$ ]] || { echo "process_phases: --isa: expected scalar, avx2 or avx512, got '$set'" >&2; exit 2; }
done
dem=${args[0]} x=${args[1]} y=${args[2]}
[[ -f "$dem" ]] || { echo "process_phases: '$dem': no such file" >&2; exit 2; }
horizon=${HORIZON_BUILD_DIR:-build}/client_cli/horizon
for tool in "$horizon" gdal_viewshed python3; do
  command -v "$tool" >/dev/null || { echo "process_phases: '$tool' not found (scripts/build.sh, scripts/setup.sh)" >&2; exit 1; }
done
columns=("${isas[@]}")
((${#columns[@]})) || columns=("")

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
now() { date +%s.%N; }
for ((i = 0; i < repeats; i++)); do
  t0=$(now)
  gdal_viewshed -q -ox "$x" -oy "$y" -oz 2 -cc 0.85714 "$dem" "$work/gdal.tif" >"$work/run.log" 2>&1 ||
    { cat "$work/run.log" >&2; exit 1; }
  t1=$(now)
  echo "gdal $t0 $t1" >>"$work/times"
  rm -f "$work/gdal.tif"
  for c in "${!columns[@]}"; do
    set=${columns[c]}
    t0=$(now)
    "$horizon" viewshed "$dem" --observer "$x,$y" --height 2 ${set:+--isa "$set"} -o "$work/hz.tif" --json \
      >"$work/hz-$c-$i.json" 2>"$work/run.log" || { cat "$work/run.log" >&2; exit 1; }
    t1=$(now)
    echo "$c $t0 $t1 $work/hz-$c-$i.json" >>"$work/times"
    rm -f "$work/hz.tif" "$work/hz.qml"
  done
done

python3 - "$work/times" "$dem" "$repeats" "${columns[@]}" <<'EOF'
import json, statistics, subprocess, sys
times, dem, repeats, columns = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
gdal, runs = [], {c: [] for c in range(len(columns))}
for line in open(times):
    f = line.split()
    wall = (float(f[2]) - float(f[1])) * 1e3
    if f[0] == "gdal":
        gdal.append(wall)
        continue
    j = json.load(open(f[3]))
    p = {k: (v or 0.0) * 1e3 for k, v in j["phases"].items()}
    p["start and exit"] = wall - j["total_seconds"] * 1e3
    p["whole process"] = wall
    runs[int(f[0])].append((p, j["kernels"], j["evaluated_cells"]))
cpu = open("/proc/cpuinfo").read()
model = next(l.split(":", 1)[1].strip() for l in cpu.splitlines() if l.startswith("model name"))
flags = next(l for l in cpu.splitlines() if l.startswith("flags")).split()
isa = "AVX-512 and AVX2" if "avx512f" in flags else "AVX2" if "avx2" in flags else "no AVX2"
date = subprocess.run(["date", "-u", "+%F %H:%M"], capture_output=True, text=True).stdout.strip()
print(f"{dem}: {runs[0][0][2]:,} cells evaluated; {model}, {isa}; {date} UTC; medians of {repeats}")
print()
names = [r[0][1] for r in runs.values()]
print("| phase | " + " | ".join(f"horizon ({n})" for n in names) + " |")
print("|---|" + "---:|" * len(names))
g = statistics.median(gdal)
for phase in ["open", "read", "compute", "mask", "encode", "other", "start and exit", "whole process"]:
    cells = [f"{statistics.median(r[0][phase] for r in runs[c]):.1f} ms" for c in runs]
    if phase == "whole process":
        cells = [f"**{c}**" for c in cells]
    print(f"| {phase} | " + " | ".join(cells) + " |")
ratios = [f"{g / statistics.median(r[0]['whole process'] for r in runs[c]):.2f}x" for c in runs]
print(f"| gdal_viewshed, whole process: {g:.1f} ms; gdal / horizon | " + " | ".join(ratios) + " |")
EOF
