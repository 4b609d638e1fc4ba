#!/usr/bin/env bash
# Installs what is needed, builds, and computes the viewshed from the summit
# of Mount Everest over a bundled SRTM crop, writing a GeoTIFF and a PNG
# preview into ./out/. SRTM has a void on the summit itself, so the eye is
# given as an absolute altitude (8850 m) rather than a height above ground.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

scripts/setup.sh
scripts/build.sh

mkdir -p out
horizon="${HORIZON_BUILD_DIR:-build}/client_cli/horizon"
dem=data/dem/everest_summit_voids_srtm3_300x300.tif
"$horizon" info "$dem"
echo
"$horizon" viewshed "$dem" \
  --lat 27.9881 --lon 86.9250 --altitude 8850 \
  -o out/everest_viewshed.tif --png out/everest_viewshed.png

echo
echo "Files written:"
echo "  $PWD/out/everest_viewshed.tif  (GeoTIFF: 1 visible, 0 hidden, 255 no data; open it in QGIS)"
echo "  $PWD/out/everest_viewshed.png  (preview: visible blue, hidden vermillion, voids hatched; legend, scale bar, north arrow)"
