// `horizon datasets --server HOST:PORT`: what a daemon holds.
#include "commands/command.hpp"
#include "remote/remote.hpp"

namespace horizon::cli {
namespace {

constexpr FlagSpec kFlags[] = {
    remote::kServerFlag,
    remote::kDeadlineFlag,
    remote::kCaFlag,
    remote::kClientCertFlag,
    remote::kTokenFileFlag,
    {"--page-size", "", "N", "Datasets asked per call (default 100); all pages are listed"},
    {"--json", "", "", "Print a JSON document"},
};

int run_datasets(const Args& args) {
  if (!args.positionals().empty()) throw UsageError("unexpected operand '" + args.positionals().front() + "'");
  if (!args.has("--server")) throw UsageError("datasets lists a daemon's datasets: give --server HOST:PORT");
  return remote::run_datasets(args, args.has("--json"));
}

}  // namespace

const Command& datasets_command() {
  static const Command command{
      "datasets",
      "List the datasets a horizond daemon holds (needs --server)",
      "horizon datasets --server HOST:PORT [--json]",
      "Lists every dataset the daemon holds resident: name, size, CRS, cell size and\n"
      "the memory it holds. Their names are the DEM operand of the other commands in\n"
      "--server mode.",
      kFlags,
      "  horizon datasets --server localhost:50051\n",
      run_datasets,
  };
  return command;
}

}  // namespace horizon::cli
