// horizon/evaluation/peers.hpp — running other viewshed programs on the same
// DEM and observer, for `horizon bench`.
//
// Peers are external programs found on PATH, never linked:
//   * gdal   gdal_viewshed (Debian gdal-bin): one process per run, timed as a
//            whole process (read + compute + write), as a user would run it.
//            Visible mask from -om NORMAL (-vv 1 -iv 0 -ov 255); minimum target
//            height above ground from one more, untimed run with -om GROUND, so its OHF error
//            can be measured (OHF = z + height).
//   * grass  GRASS r.viewshed through `grass --tmp-location DEM --exec`: the
//            DEM is imported (r.in.gdal), then r.viewshed -b runs and is timed
//            alone (import, session start and export excluded: they are GRASS
//            overheads, not the algorithm), then r.out.gdal writes the 0/1 mask.
//            r.viewshed gives no heights: its OHF error is reported as NaN.
// Both use the same observer cell centre, eye height above ground, target
// height, curvature (GDAL -cc C; GRASS -c -r with refraction 1 - C) and max
// distance. Outputs land in a caller-given directory and are removed by the
// caller.
#pragma once

#include <limits>
#include <string>

#include "horizon/common/error.hpp"

namespace horizon::evaluation {

struct PeerRequest {
  std::string dem_path;
  double x = 0, y = 0;           // observer, the DEM's CRS
  double observer_height = 2.0;  // metres above ground
  double target_height = 0.0;
  double curvature = 0.85714;
  double max_distance = std::numeric_limits<double>::infinity();
  std::string work_dir;  // outputs go here
  int repeats = 1;       // timed runs; the median is kept
};

struct PeerRun {
  std::string command;  // the timed command, for the record
  double seconds_median = 0, seconds_min = 0;
  std::string timing;        // what the time covers
  std::string mask_path;     // raster: 1 visible, 0 hidden, anything else no answer
  std::string heights_path;  // raster of minimum visible target height (m); empty when the peer has none
};

// True when the peer's program is on PATH.
bool peer_installed(std::string_view peer);  // "gdal" or "grass"

// Runs the peer; kNotFound when it is not installed, kInternal (with the
// program's output) when it fails.
Result<PeerRun> run_gdal_viewshed(const PeerRequest& request);
Result<PeerRun> run_grass_viewshed(const PeerRequest& request);

}  // namespace horizon::evaluation
