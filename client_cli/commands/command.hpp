// command.hpp — what every `horizon` sub-command provides, and the exit codes.
//
// main.cpp parses a command's flags with its FlagSpec table, answers --help
// from the texts here, and maps a thrown UsageError to exit status 2. A
// command's run() turns the parsed flags into engine structs, calls the engine
// and turns the result into files and stdout; an engine Error is printed with
// report_error() and gives exit status 1.
#pragma once

#include <memory>
#include <span>
#include <string_view>

#include "args.hpp"
#include "horizon/common/error.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/terrain/source.hpp"
#include "horizon/visibility/work_stats.hpp"

namespace horizon::cli {

enum ExitCode : int {
  kExitOk = 0,
  kExitFailure = 1,  // the engine or the file system refused (message from horizon::Error)
  kExitUsage = 2,    // the command line is wrong
};

struct Command {
  std::string_view name;         // "viewshed"
  std::string_view summary;      // one line, for `horizon --help`
  std::string_view synopsis;     // "horizon viewshed DEM (--observer X,Y | --lat LAT --lon LON) -o OUT.tif [options]"
  std::string_view description;  // paragraphs printed after the synopsis
  std::span<const FlagSpec> flags;
  std::string_view examples;  // printed last; may be empty
  int (*run)(const Args& args);
};

const Command& info_command();
const Command& viewshed_command();
const Command& los_command();
const Command& bench_command();   // horizon_evaluation
const Command& stress_command();  // horizon_evaluation
const Command& cull_command();
const Command& region_command();
const Command& datasets_command();  // --server only
const Command& session_command();
const Command& trace_command();
const Command& mesh_command();

// Prints "horizon: error: <message>" to stderr and returns kExitFailure.
int report_error(const Error& error);

// When the GPU was asked for but the CPU answered (stats.gpu_fallback set),
// prints "horizon: warning: GPU failed (<why>); answered on the CPU" to stderr.
// The run still succeeds: the answer is the CPU's.
void warn_gpu_fallback(const visibility::WorkStats& stats);

// The one EGL context behind a command's --gpu switch (bench, stress): null
// when the switch is absent, the pool's error when no context can be had.
Result<std::unique_ptr<gpu::ContextPool>> gpu_for_switch(const Args& args);

// How a command that reads a DEM through an ElevationSource opens it: from
// --band N and --valid-range MIN,MAX (kSourceFlags, in its flag table);
// UsageError for a malformed or reversed range.
terrain::SourceOptions source_options(const Args& args);
inline constexpr FlagSpec kValidRangeFlag{
    "--valid-range", "", "MIN,MAX",
    "Plausible elevations (default -12000,9000 metres); a cell outside them is refused as corrupt data"};

// Exactly one positional operand (the DEM path); UsageError otherwise.
const std::string& single_operand(const Args& args, std::string_view what);

}  // namespace horizon::cli
