// cli_run.hpp — how the CLI tests run the `horizon` built beside them.
#pragma once

#include <string>
#include <vector>

#include "test_support.hpp"

namespace horizon::testing {

// Runs `horizon ARGS...`, each argument quoted for the shell; the result
// holds its exit code and standard output (run_command).
inline CommandResult horizon(const std::vector<std::string>& args) {
  std::string command = shell_quote(HORIZON_CLI_PATH);
  for (const std::string& a : args) {
    command += ' ';
    command += shell_quote(a);
  }
  return run_command(command);
}

// Runs `NAME=value EXE ARGS...`: the environment variable `name` set for
// the built `horizon` (or `exe`).
inline CommandResult horizon_with_env(const std::string& name, const std::string& value,
                                      const std::vector<std::string>& args, const std::string& exe = HORIZON_CLI_PATH) {
  std::string command = name;
  command += '=';
  command += shell_quote(value);
  command += ' ';
  command += shell_quote(exe);
  for (const std::string& a : args) {
    command += ' ';
    command += shell_quote(a);
  }
  return run_command(command);
}

}  // namespace horizon::testing
