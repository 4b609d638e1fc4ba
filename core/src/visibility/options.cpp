// Option names and validation.
#include "horizon/visibility/options.hpp"

#include <cmath>
#include <string>
#include <utility>

namespace horizon::visibility {
namespace {

Error bad_option(const char* field, const std::string& what) {
  return make_error(ErrorCode::kInvalidArgument, std::string(field) + ": " + what, field);
}

}  // namespace

Status validate_options(const ViewshedOptions& o) {
  if (!std::isfinite(o.target_height) || o.target_height < 0)
    return bad_option("target_height", "must be a finite number >= 0 metres, got " + number_text(o.target_height));
  if (std::isnan(o.max_distance) || o.max_distance <= 0)
    return bad_option("max_distance", "must be > 0 metres (or infinite for no limit), got " + number_text(o.max_distance));
  if (!std::isfinite(o.curvature_coefficient) || o.curvature_coefficient < 0 || o.curvature_coefficient > 2)
    return bad_option("curvature_coefficient",
                      "must be a finite number in [0, 2] (0.85714 = standard refraction, 0 = flat earth), got " +
                          number_text(o.curvature_coefficient));
  HORIZON_RETURN_IF_ERROR(validate_field_of_view(o.field_of_view));
  if (o.field_of_view.min_distance > 0 && !(o.field_of_view.min_distance < o.max_distance))
    return bad_option("min_distance", "must be below max_distance (" + number_text(o.max_distance) +
                                          " metres), got " + number_text(o.field_of_view.min_distance));
  if (!std::isfinite(o.nodata_fill_height))
    return bad_option("nodata_fill_height", "must be a finite number of metres, got " + number_text(o.nodata_fill_height));
  if (!std::isfinite(o.radial.ray_spacing) || o.radial.ray_spacing <= 0 || o.radial.ray_spacing > 4)
    return bad_option("ray_spacing", "must be in (0, 4] cells, got " + number_text(o.radial.ray_spacing));
  if (o.radial.thinning_levels < 0 || o.radial.thinning_levels > 6)
    return bad_option("thinning_levels", "must be an integer in [0, 6], got " + number_text(o.radial.thinning_levels));
  switch (o.radial.blend) {
    case RayBlend::kLinear:
    case RayBlend::kMin:
    case RayBlend::kResample:
      break;
    default:
      return bad_option("blend", "unknown ray blend value " + number_text(static_cast<int>(o.radial.blend)));
  }
  if (o.gpu) switch (o.gpu->method) {
      case GpuMethod::kFragment:
      case GpuMethod::kCompute:
        break;
      default:
        return bad_option("gpu_method", "unknown GPU method value " + number_text(static_cast<int>(o.gpu->method)));
    }
  switch (o.backend) {
    case Backend::kAuto:
    case Backend::kCpu:
      break;
    case Backend::kGpu:
      if (o.algorithm != Algorithm::kRadial)
        return bad_option("backend", "the GPU backend computes algorithm fast only; algorithm " +
                                         std::string(algorithm_name(o.algorithm)) + " runs on the CPU (backend auto or cpu)");
      break;
    default:
      return bad_option("backend", "unknown backend value " + number_text(static_cast<int>(o.backend)));
  }
  switch (o.algorithm) {
    case Algorithm::kRadial:
    case Algorithm::kR3:
    case Algorithm::kExact:
    case Algorithm::kConservative:
      return Status::Ok();
  }
  return bad_option("algorithm", "unknown algorithm value " + number_text(static_cast<int>(o.algorithm)));
}

namespace {
struct NamedAlgorithm {
  Algorithm algorithm;
  std::string_view name;
};
constexpr NamedAlgorithm kNames[] = {{Algorithm::kRadial, "fast"},
                                     {Algorithm::kR3, "r3"},
                                     {Algorithm::kExact, "exact"},
                                     {Algorithm::kConservative, "conservative"}};
constexpr std::pair<Backend, std::string_view> kBackends[] = {
    {Backend::kAuto, "auto"}, {Backend::kCpu, "cpu"}, {Backend::kGpu, "gpu"}};
constexpr std::pair<GpuMethod, std::string_view> kGpuMethods[] = {{GpuMethod::kFragment, "fragment"},
                                                                  {GpuMethod::kCompute, "compute"}};

template <class T, std::size_t N>
std::string_view name_of(const std::pair<T, std::string_view> (&table)[N], T value) {
  for (const auto& [v, name] : table)
    if (v == value) return name;
  return "unknown";
}

template <class T, std::size_t N>
std::optional<T> value_of(const std::pair<T, std::string_view> (&table)[N], std::string_view name) {
  for (const auto& [v, n] : table)
    if (n == name) return v;
  return std::nullopt;
}
}  // namespace

std::string_view backend_name(Backend backend) { return name_of(kBackends, backend); }
std::optional<Backend> parse_backend(std::string_view name) { return value_of(kBackends, name); }
std::string_view gpu_method_name(GpuMethod method) { return name_of(kGpuMethods, method); }
std::optional<GpuMethod> parse_gpu_method(std::string_view name) { return value_of(kGpuMethods, name); }

std::string gpu_variant_name(const GpuOptions& options) {
  return std::string(gpu_method_name(options.method)) + (options.log_step ? ", log-step" : ", one-step");
}

std::string_view algorithm_name(Algorithm algorithm) {
  for (const auto& n : kNames)
    if (n.algorithm == algorithm) return n.name;
  return "unknown";
}

std::optional<Algorithm> parse_algorithm(std::string_view name) {
  for (const auto& n : kNames)
    if (n.name == name) return n.algorithm;
  return std::nullopt;
}

}  // namespace horizon::visibility
