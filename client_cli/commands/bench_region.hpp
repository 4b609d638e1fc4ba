// bench_region.hpp — `horizon bench --region DEM...`: the from-region
// sweep (evaluation/region_bench.hpp) from the bench command's flags;
// bench.cpp hands over when --region is given.
#pragma once

#include <string>
#include <string_view>

#include "args.hpp"

namespace horizon::cli {

// Flags of the region sweep alone (bench.cpp lists them with its own).
inline constexpr std::string_view kRegionOnlyFlags[] = {"--sizes",     "--face-resolutions", "--splits",  "--rows",
                                                        "--seed-rows", "--heights",          "--regions", "--check"};
// Flags of the viewshed sweep that mean nothing with --region.
inline constexpr std::string_view kViewshedOnlyFlags[] = {"--observers", "--observer", "--algorithms",
                                                          "--peers",     "--height",   "--gpu"};

int run_region_bench(const Args& args);

// A DEM path's file stem as a file-name piece (letters, digits, '_', '-').
std::string dem_slug(const std::string& dem);

}  // namespace horizon::cli
