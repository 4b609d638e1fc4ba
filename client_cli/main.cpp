// horizon — the command-line client, embedded mode: the engine runs in this
// process on local files. This file dispatches to a sub-command, answers
// --help/--version, and maps usage mistakes to exit status 2 (engine failures
// are reported by the commands themselves, exit status 1).
#include <cstdio>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include "args.hpp"
#include "commands/command.hpp"

#ifndef HORIZON_VERSION
#error "HORIZON_VERSION must be defined by the build"
#endif

namespace horizon::cli {
namespace {

const Command* const kCommands[] = {&info_command(),   &viewshed_command(), &los_command(),    &bench_command(),
                                    &stress_command(), &cull_command(),     &region_command(), &session_command(),
                                    &trace_command(),  &mesh_command(),     &datasets_command()};

const Command* find_command(std::string_view name) {
  for (const Command* c : kCommands)
    if (c->name == name) return c;
  return nullptr;
}

void print_general_help(std::ostream& out) {
  out << "horizon " HORIZON_VERSION " — terrain visibility on local DEM files\n\n"
      << "Usage: horizon COMMAND [ARGS...]\n"
      << "       horizon help COMMAND | horizon COMMAND --help\n"
      << "       horizon --version\n\n"
      << "Commands:\n";
  for (const Command* c : kCommands) {
    std::string name(c->name);
    name.resize(10, ' ');
    out << "  " << name << c->summary << '\n';
  }
  out << "\nExit status: 0 success, 1 failure (bad data, I/O), 2 usage error.\n";
}

void print_command_help(const Command& c, std::ostream& out) {
  std::vector<FlagSpec> flags(c.flags.begin(), c.flags.end());
  flags.push_back({"--help", "-h", "", "Show this help"});
  out << "Usage: " << c.synopsis << "\n\n" << c.description << "\n\nOptions:\n" << format_flag_table(flags);
  if (!c.examples.empty()) out << "\nExamples:\n" << c.examples;
}

int usage_error(const std::string& message, std::string_view command) {
  std::fprintf(stderr, "horizon: error: %s\n", message.c_str());
  if (command.empty())
    std::fprintf(stderr, "Run 'horizon --help' for usage.\n");
  else
    std::fprintf(stderr, "Run 'horizon %.*s --help' for usage.\n", static_cast<int>(command.size()), command.data());
  return kExitUsage;
}

int run(const std::vector<std::string>& argv) {
  if (argv.empty()) {
    print_general_help(std::cerr);
    return kExitUsage;
  }
  const std::string& first = argv[0];
  if (first == "--help" || first == "-h") {
    print_general_help(std::cout);
    return kExitOk;
  }
  if (first == "--version" || first == "-V") {
    std::cout << "horizon " HORIZON_VERSION "\n";
    return kExitOk;
  }
  if (first == "help") {
    if (argv.size() == 1) {
      print_general_help(std::cout);
      return kExitOk;
    }
    if (argv.size() > 2) return usage_error("help: expected one command name", "");
    const Command* c = find_command(argv[1]);
    if (!c) return usage_error("unknown command '" + argv[1] + "'", "");
    print_command_help(*c, std::cout);
    return kExitOk;
  }
  const Command* command = find_command(first);
  if (!command) {
    if (first.starts_with("-")) return usage_error("unknown option '" + first + "' (give a command first)", "");
    return usage_error("unknown command '" + first + "'", "");
  }

  try {
    const std::vector<std::string> rest(argv.begin() + 1, argv.end());
    const Args args = Args::parse(rest, command->flags);
    if (args.help_requested()) {
      print_command_help(*command, std::cout);
      return kExitOk;
    }
    return command->run(args);
  } catch (const UsageError& e) {
    return usage_error(e.what(), command->name);
  }
}

}  // namespace
}  // namespace horizon::cli

int main(int argc, char** argv) {
  try {
    return horizon::cli::run(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const std::exception& e) {
    // Only allocation failure or a library bug gets here; the engine itself never throws.
    std::fprintf(stderr, "horizon: error: %s\n", e.what());
    return horizon::cli::kExitFailure;
  }
}
