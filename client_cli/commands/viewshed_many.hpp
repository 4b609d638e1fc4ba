// viewshed_many.hpp — `horizon viewshed` with many observers (--observers
// FILE, or --observer given more than once): the --accumulate raster
// (count of observers seeing each cell, or seen by any / by all), a PNG of
// the count as a ramp or the any/all answer, and a per-observer --summary table.
#pragma once

#include "args.hpp"

namespace horizon::cli {

// True when the command line names more than one observer.
bool wants_many_observers(const Args& args);
// UsageError for the many-observer flags on a one-observer command line.
void refuse_many_flags(const Args& args);
int run_many_observers(const Args& args);

}  // namespace horizon::cli
