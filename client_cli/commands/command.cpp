#include "commands/command.hpp"

#include <cstdio>

namespace horizon::cli {

int report_error(const Error& error) {
  std::fprintf(stderr, "horizon: error: %s\n", error.message.c_str());
  return kExitFailure;
}

void warn_gpu_fallback(const visibility::WorkStats& stats) {
  if (!stats.gpu_fallback.empty())
    std::fprintf(stderr, "horizon: warning: GPU failed (%s); answered on the CPU\n", stats.gpu_fallback.c_str());
}

Result<std::unique_ptr<gpu::ContextPool>> gpu_for_switch(const Args& args) {
  if (!args.has("--gpu")) return std::unique_ptr<gpu::ContextPool>();
  return gpu::ContextPool::create({.contexts = 1});
}

const std::string& single_operand(const Args& args, std::string_view what) {
  const auto& operands = args.positionals();
  if (operands.empty()) throw UsageError("missing " + std::string(what) + " operand");
  if (operands.size() > 1) throw UsageError("unexpected extra operand '" + operands[1] + "'");
  return operands.front();
}

terrain::SourceOptions source_options(const Args& args) {
  terrain::SourceOptions o;
  o.band = args.positive_integer("--band").value_or(0);
  if (args.has("--server") && args.has("--valid-range"))
    throw UsageError(
        "--valid-range applies to a local DEM; with --server the dataset's valid_range in the "
        "daemon's config decides");
  if (auto range = args.pair("--valid-range")) {
    if (!(range->first < range->second))
      throw UsageError("--valid-range: the minimum must be below the maximum, got " + *args.text("--valid-range"));
    o.valid_min = range->first;
    o.valid_max = range->second;
  }
  return o;
}

}  // namespace horizon::cli
