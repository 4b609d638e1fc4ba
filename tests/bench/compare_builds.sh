#!/usr/bin/env bash
# Do two builds of `horizon` give the same answers? For a change meant to
# make the engine faster without changing what it computes.
#
#   [ALGORITHMS=fast,conservative] [BACKEND=cpu|gpu|auto] tests/bench/compare_builds.sh OLD_HORIZON NEW_HORIZON DEM...
#
# ALGORITHMS: comma-separated, default "fast,conservative". For every DEM it
# writes the OHF raster (`--output ohf`, float32) of each algorithm with both
# binaries for two observers (the DEM's centre, and 21 % east / 17 % south
# of it; eye 2 m, whole DEM) and compares the files byte for byte (the
# writer is deterministic). A run that fails with both binaries (e.g. an
# observer on nodata) is counted as such, not as a difference. Prints one
# line per difference or failure and a summary; exits 1 when any output
# differs or only one binary fails. BACKEND, when set, is passed as
# `--backend` (gpu: the fast algorithm's GL form, on llvmpipe without a GPU).
#
# Needs gdalinfo (gdal-bin) for the DEM's extent. Example, old build in a
# worktree:
#   git worktree add /tmp/old <commit> && (cd /tmp/old && scripts/build.sh)
#   tests/bench/compare_builds.sh /tmp/old/build/client_cli/horizon build/client_cli/horizon \
#       ../shared/data/dem/*.tif ../shared/data/dem/*.hgt
set -euo pipefail

if (($# < 3)); then
  sed -n '2,22p' "$0" >&2
  exit 2
fi
old=$1
new=$2
shift 2
algorithms=${ALGORITHMS:-fast,conservative}
backend_args=()
[[ -n "${BACKEND:-}" ]] && backend_args=(--backend "$BACKEND")
for tool in "$old" "$new" gdalinfo; do
  command -v "$tool" >/dev/null || { echo "compare_builds: '$tool' not found" >&2; exit 2; }
done

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
same=0 different=0 both_failed=0 one_failed=0
for dem in "$@"; do
  if [[ ! -f "$dem" ]]; then
    echo "skipped, not a file: $dem"  # e.g. a glob that matched nothing
    continue
  fi
  # Centre and size of the DEM in its own CRS.
  read -r cx cy w h < <(gdalinfo -json "$dem" | python3 -c "
import json, sys
c = json.load(sys.stdin)['cornerCoordinates']
print(c['center'][0], c['center'][1], c['upperRight'][0] - c['upperLeft'][0], c['upperLeft'][1] - c['lowerLeft'][1])")
  for offset in "0 0" "0.21 -0.17"; do
    read -r fx fy <<<"$offset"
    x=$(python3 -c "print($cx + $fx * $w)")
    y=$(python3 -c "print($cy + $fy * $h)")
    for algorithm in ${algorithms//,/ }; do
      args=(viewshed "$dem" --observer "$x,$y" --height 2 --algorithm "$algorithm" --output ohf "${backend_args[@]}")
      rc_old=0 rc_new=0
      "$old" "${args[@]}" -o "$work/old.tif" >/dev/null 2>&1 || rc_old=$?
      "$new" "${args[@]}" -o "$work/new.tif" >/dev/null 2>&1 || rc_new=$?
      if ((rc_old != 0 && rc_new != 0)); then
        both_failed=$((both_failed + 1))
        echo "both failed ($rc_old, $rc_new): $dem $algorithm at $x,$y"
      elif ((rc_old != 0 || rc_new != 0)); then
        one_failed=$((one_failed + 1))
        echo "ONE FAILED (old $rc_old, new $rc_new): $dem $algorithm at $x,$y"
      elif cmp -s "$work/old.tif" "$work/new.tif"; then
        same=$((same + 1))
      else
        different=$((different + 1))
        echo "DIFFERENT: $dem $algorithm at $x,$y"
      fi
    done
  done
done
echo "identical $same, different $different, failed with both $both_failed, failed with one $one_failed"
((different == 0 && one_failed == 0))
