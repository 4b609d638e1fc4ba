#!/usr/bin/env bash
# From-region soundness and effectiveness on every shared DEM: for two
# regions a DEM (small near the ground; large and high), `horizon region
# --check` samples corners, edge midpoints, 8 points a face and N interior
# points and checks every verdict with exact R3. Prints one Markdown row a
# case: wrong verdicts (must be 0), the share of R3-hidden (from every
# sample) the method decides, and the time.
#   tests/bench/region_check.sh [BUILD_DIR] [INTERIOR_POINTS] [DEM_DIR]
set -euo pipefail
build="${1:-build}"
points="${2:-1000}"
dems="${3:-$(dirname "$0")/../../../shared/data/dem}"
horizon="$build/client_cli/horizon"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT

echo "| DEM | region | cells | hidden | visible | undetermined | wrong | decided of R3-hidden | decided of R3-visible | s |"
echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"
for dem in "$dems"/*.tif; do
  name="$(basename "$dem" .tif)"
  info="$(gdalinfo -json "$dem")"
  read -r cx cy px <<<"$(python3 -c '
import json, sys
j = json.loads(sys.argv[1]); g = j["geoTransform"]; w, h = j["size"]
print(g[0] + g[1] * w / 2, g[3] + g[5] * h / 2, abs(g[1]))' "$info")"
  for kind in small large; do
    if [ "$kind" = small ]; then half=3; heights=2,20; label="6 cells, 2-20 m up"
    else half=20; heights=100,300; label="40 cells, 100-300 m up"; fi
    box="$(python3 -c "import sys; c,d,p,k=map(float,sys.argv[1:]); print(f'{c-k*p},{d-k*p},{c+k*p},{d+k*p}')" \
           "$cx" "$cy" "$px" "$half")"
    if ! json="$("$horizon" region "$dem" --from-box "$box" --heights "$heights" --max-distance 3000 \
                   --target-height 1.5 -o "$out/r.tif" --check "$points" --json 2>"$out/err")"; then
      echo "| $name | $label | refused: $(head -c 120 "$out/err" | tr '\n|' '  ') |||||||||"
      continue
    fi
    python3 -c '
import json, sys
j = json.loads(sys.argv[1]); s = j["stats"]; c = j["check"]
pct = lambda a, b: "%.0f %%" % (100.0 * a / b) if b else "-"
row = [sys.argv[2], sys.argv[3], str(s["items"]), pct(s["always_hidden"], s["items"]),
       pct(s["always_visible"], s["items"]), pct(s["undetermined"], s["items"]),
       str(c["wrong_hidden"] + c["wrong_visible"]), pct(c["hidden_checked"], c["sampled_hidden"]),
       pct(c["visible_checked"], c["sampled_visible"]), "%.3f" % s["seconds"]]
print("| " + " | ".join(row) + " |")' "$json" "$name" "$label"
  done
done
