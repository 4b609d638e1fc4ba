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

}  // namespace horizon::testing
