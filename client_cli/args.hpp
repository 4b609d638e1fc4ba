// args.hpp — the `horizon` command line, parsed by hand.
//
// Grammar, per command: positional operands and flags in any order.
//   --name VALUE | --name=VALUE   a flag with a value (the value may start with '-')
//   --name                        a switch
//   -o VALUE                      a short alias (a flag may have several:
//                                 "-f -of", gdal_viewshed's spellings)
//   --                            everything after it is positional
//   --help | -h                   stops parsing; the command prints its help
// Unknown flags (with the nearest declared spelling suggested), a missing
// value, a value given to a switch and a repeated flag (unless declared
// repeatable) are usage errors. The typed getters check a value's syntax and
// basic range and throw UsageError with a message that names the flag as the
// user typed it and quotes the value ("-md: expected a non-negative number,
// got 'abc'"). Range checks that belong to the engine
// (visibility::validate_options) stay there.
#pragma once

#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace horizon::cli {

// A mistake on the command line: exit status 2, message names the flag.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct FlagSpec {
  std::string_view name;    // long form, "--max-distance"
  std::string_view alias;   // short forms separated by spaces ("-o", "-f -of") or empty
  std::string_view value;   // metavariable shown in help ("M", "X,Y"); empty for a switch
  std::string_view help;    // one line; defaults and units included
  bool repeatable = false;  // may be given several times (read with Args::all)
};

class Args {
 public:
  // Throws UsageError. `specs` must outlive the Args.
  static Args parse(std::span<const std::string> argv, std::span<const FlagSpec> specs);

  bool help_requested() const { return help_; }
  const std::vector<std::string>& positionals() const { return positionals_; }

  // True when the flag (switch or valued) was given.
  bool has(std::string_view flag) const;
  // The raw value, or nullopt when the flag was not given (a repeatable
  // flag: its first value).
  std::optional<std::string> text(std::string_view flag) const;
  // Every value of a flag, in command-line order.
  std::vector<std::string> all(std::string_view flag) const;
  // How many times the flag was given.
  std::size_t count(std::string_view flag) const;
  // The flag as the user spelled it ("-md" for --max-distance), for
  // messages; its long name when it was not given (or is not declared).
  std::string typed(std::string_view flag) const;

  // Typed getters: nullopt when absent, UsageError when malformed.
  std::optional<double> number(std::string_view flag) const;        // finite
  std::optional<double> non_negative(std::string_view flag) const;  // finite, >= 0
  std::optional<int> positive_integer(std::string_view flag) const;
  std::optional<unsigned> non_negative_integer(std::string_view flag) const;
  // Two finite numbers separated by one comma, in the shape the flag
  // declares ("X,Y", "MIN,MAX"), which messages repeat.
  std::optional<std::pair<double, double>> pair(std::string_view flag) const;
  // One of `allowed`, spelled exactly.
  std::optional<std::string> choice(std::string_view flag, std::span<const std::string_view> allowed) const;

 private:
  const FlagSpec& spec(std::string_view flag) const;  // asserts the flag is declared

  std::span<const FlagSpec> specs_;
  struct Given {
    std::string_view name;  // the flag's long name
    std::string value;      // "" for switches
    std::string typed;      // as on the command line: the long name or an alias
  };
  std::vector<Given> values_;
  std::vector<std::string> positionals_;
  bool help_ = false;
};

// Parses a finite decimal number (the whole string); nullopt otherwise. Also
// used for the parts of compound values such as "fill:H".
std::optional<double> parse_finite(std::string_view text);

// Help lines for a flag table, aligned: "  --height M        Observer height ...".
std::string format_flag_table(std::span<const FlagSpec> specs);

// The declared spelling (a long name or an alias) nearest to `token` by
// edit distance, when one is near enough to be a likely typo ("--max-distnace"
// -> "--max-distance"); empty otherwise.
std::string nearest_flag(std::string_view token, std::span<const FlagSpec> specs);

}  // namespace horizon::cli
