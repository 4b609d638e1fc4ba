// horizon/visibility/options.hpp — what a viewshed request may tune.
//
// One struct for every algorithm; each algorithm reads the knobs that apply to
// it and ignores the rest. Validation (finite, in range) happens once in
// validate_options(), at the engine's entry.
#pragma once

#include <limits>
#include <optional>
#include <string>
#include <string_view>

#include "horizon/common/error.hpp"
#include "horizon/visibility/field_of_view.hpp"

namespace horizon::visibility {

// The algorithm, named by the accuracy it promises (names as the CLI, the API
// and `horizon bench` spell them: algorithm_name() / parse_algorithm()).
enum class Algorithm {
  kRadial,        // "fast" (default): perspective-modulated radial max propagation (patent 7,027,046), O(cells)
  kR3,            // "r3": the exact reference, every target's segment tested at every grid-line crossing
  kExact,         // "exact": R3's answers, computed faster than R3
  kConservative,  // "conservative": never reports hidden what R3 sees (0 missed-visible); may over-report visible
};

enum class NodataPolicy {
  kTransparent,  // voids never block a sight line; void targets get no answer (nodata)
  kFill,         // voids are terrain at `nodata_fill_height` (e.g. 0 for a NaN sea)
};

// How the radial sweep turns the horizons of the two rays that bracket a
// cell centre into that cell's horizon.
enum class RayBlend {
  kLinear,  // interpolate by angle (default; balanced errors)
  kMin,     // take the lower horizon (errs towards "visible")
  kResample,  // re-sample the cell's own sight line where the bracketing rays found their horizons
};

struct RadialOptions {
  // Lateral spacing of the rays, in cells, at the far edge of each sweep
  // sector (they are closer everywhere else). Smaller is slower and closer to
  // R3. (0, 4].
  double ray_spacing = 1.0;
  RayBlend blend = RayBlend::kResample;
  // Thin the rays near the eye by up to this many halvings (0 = every ray
  // marches the whole way). Fewer ray steps, at some accuracy: a ray that
  // joins mid-way has only its neighbours' horizons for the path behind it.
  // [0, 6].
  int thinning_levels = 0;
};

// Where the fast algorithm runs (the others always run on the CPU).
enum class Backend {
  kAuto,  // the GPU when a hardware one is present and measured faster for the request's size, else the CPU
  kCpu,   // the radial sweep on the CPU (radial_sweep.hpp)
  kGpu,   // the same rays on an EGL context (visibility/radial_sweep_gl.hpp); a GL failure is answered by the CPU path
};

// The GL formulation of the fast algorithm (visibility/radial_sweep_gl.hpp).
enum class GpuMethod {
  kFragment,  // render passes into R32F/RG32F targets (the patent's modulation and shift disks)
  kCompute,   // compute-shader passes over the same images
};

// One GL variant of the fast algorithm; all give the same OHF.
struct GpuOptions {
  GpuMethod method = GpuMethod::kFragment;
  // Propagate by shift doubling: log2(N) passes of shifts 1, 2, 4, ... instead
  // of N passes of a one-texel shift (same result, far fewer passes).
  bool log_step = true;
};

// "fragment, log-step", "compute, one-step", ...
std::string gpu_variant_name(const GpuOptions& options);

struct ViewshedOptions {
  double target_height = 0.0;  // metres above ground at each target cell, >= 0
  // Ground distance limit in metres; +infinity = the whole DEM. Cells beyond it
  // are neither computed nor written.
  double max_distance = std::numeric_limits<double>::infinity();
  // GDAL's curvature/refraction coefficient: a point at ground distance d
  // appears lowered by coefficient * d^2 / (2 R). 1 - k with k the refraction
  // coefficient (GRASS's refraction_coeff, 0.14286: see
  // curvature_from_refraction); 0.85714 (k = 1/7) by default, 0 disables
  // (a flat earth), 1 = curvature without refraction. [0, 2].
  double curvature_coefficient = 0.85714;
  // What the observer looks at: cells outside it get no answer, as those
  // beyond max_distance (field_of_view.hpp). Default: everything in reach.
  FieldOfView field_of_view;
  NodataPolicy nodata = NodataPolicy::kTransparent;
  double nodata_fill_height = 0.0;  // metres, for NodataPolicy::kFill
  Algorithm algorithm = Algorithm::kRadial;
  RadialOptions radial;
  unsigned threads = 0;  // worker threads; 0 = all hardware threads
  Backend backend = Backend::kAuto;
  // The GL variant; absent: the backend policy's preferred one, measured
  // fastest on the device (visibility::calibrate), fragment with log-step
  // until measured (backend_policy.hpp).
  std::optional<GpuOptions> gpu;
  // The caller needs the visible/hidden answer at target_height only (the
  // viewshed raster), not the OHF or the minimum visible target height.
  // "exact" then decides each cell as R3 does without finding R3's OHF
  // (exact.hpp), several times faster; the OHF it leaves gives R3's
  // visibility at target_height and nothing more. Other algorithms ignore it.
  bool visibility_only = false;
  // The caller reads the visibility mask at target_height only, never the
  // OHF: ViewshedResult::mask holds it (visibility_mask()'s codes) with its
  // counts. Fast on the CPU, re-sampling blend, no field of view then codes
  // each cell inside the sweep and leaves result.ohf empty (radial_mask);
  // any other run codes its OHF as visibility_mask() does, the same bytes.
  bool mask_only = false;
};

// "fast", "r3", "exact", "conservative".
std::string_view algorithm_name(Algorithm algorithm);
std::optional<Algorithm> parse_algorithm(std::string_view name);

// "auto", "cpu", "gpu" and "fragment", "compute".
std::string_view backend_name(Backend backend);
std::optional<Backend> parse_backend(std::string_view name);
std::string_view gpu_method_name(GpuMethod method);
std::optional<GpuMethod> parse_gpu_method(std::string_view name);

// Checks every field: finite, non-negative distances/heights, knob ranges,
// the field of view (and its min_distance below max_distance). The error's
// field names the option ("max_distance", "pitch_min").
Status validate_options(const ViewshedOptions& options);

// GDAL's curvature coefficient from GRASS's refraction coefficient k
// (r.viewshed -c -r refraction_coeff=k): 1 - k. Standard refraction is
// k = 1/7 = 0.14286 (coefficient 0.85714); k = 0 is curvature without
// refraction, k = 1 a flat earth. No range check: validate_options checks the
// coefficient it gives ([0, 2], so k in [-1, 1]).
inline double curvature_from_refraction(double refraction_coefficient) {
  return 1.0 - refraction_coefficient;
}

}  // namespace horizon::visibility
