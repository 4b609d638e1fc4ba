#include "args.hpp"

#include <algorithm>
#include <cassert>
#include <charconv>
#include <cmath>
#include <limits>
#include <system_error>

namespace horizon::cli {
namespace {

// The whole of `text` as a double (from_chars also accepts "nan" and "inf",
// which the callers then reject by name).
std::optional<double> parse_double(std::string_view text) {
  double value = 0.0;
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || ptr != end) return std::nullopt;
  return value;
}

std::optional<long long> parse_integer(std::string_view text) {
  long long value = 0;
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || ptr != end) return std::nullopt;
  return value;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

[[noreturn]] void bad_value(std::string_view flag, std::string_view expected, std::string_view got) {
  throw UsageError(std::string(flag) + ": expected " + std::string(expected) + ", got '" + std::string(got) + "'");
}

const FlagSpec* find_spec(std::span<const FlagSpec> specs, std::string_view token) {
  for (const FlagSpec& s : specs)
    if (s.name == token || (!s.alias.empty() && s.alias == token)) return &s;
  return nullptr;
}

}  // namespace

std::optional<double> parse_finite(std::string_view text) {
  auto v = parse_double(text);
  if (!v || !std::isfinite(*v)) return std::nullopt;
  return v;
}

Args Args::parse(std::span<const std::string> argv, std::span<const FlagSpec> specs) {
  Args args;
  args.specs_ = specs;
  bool flags_done = false;
  for (std::size_t i = 0; i < argv.size(); ++i) {
    const std::string& token = argv[i];
    if (flags_done || token.size() < 2 || token[0] != '-') {
      args.positionals_.push_back(token);
      continue;
    }
    if (token == "--") {
      flags_done = true;
      continue;
    }
    if (token == "--help" || token == "-h") {
      args.help_ = true;
      return args;
    }
    // "--name=value" carries its value inline; short aliases never do.
    std::string_view name = token;
    std::optional<std::string> inline_value;
    if (token.starts_with("--")) {
      if (auto eq = token.find('='); eq != std::string::npos) {
        name = std::string_view(token).substr(0, eq);
        inline_value = token.substr(eq + 1);
      }
    }
    const FlagSpec* spec = find_spec(specs, name);
    if (!spec) throw UsageError("unknown flag '" + std::string(name) + "'");
    const bool repeated = std::any_of(args.values_.begin(), args.values_.end(),
                                      [&](const auto& entry) { return entry.first == spec->name; });
    if (repeated && !spec->repeatable) throw UsageError(std::string(spec->name) + ": given more than once");

    if (spec->value.empty()) {
      if (inline_value) throw UsageError(std::string(spec->name) + ": takes no value, got '" + *inline_value + "'");
      args.values_.emplace_back(spec->name, std::string());
      continue;
    }
    if (!inline_value) {
      if (i + 1 >= argv.size())
        throw UsageError(std::string(spec->name) + ": missing value (expected " + std::string(spec->value) + ")");
      inline_value = argv[++i];
    }
    args.values_.emplace_back(spec->name, std::move(*inline_value));
  }
  return args;
}

const FlagSpec& Args::spec(std::string_view flag) const {
  const FlagSpec* s = find_spec(specs_, flag);
  assert(s && "flag queried but not declared in the command's FlagSpec table");
  return *s;
}

bool Args::has(std::string_view flag) const {
  return text(flag).has_value();
}

std::optional<std::string> Args::text(std::string_view flag) const {
  const std::string_view name = spec(flag).name;
  for (const auto& [key, value] : values_)
    if (key == name) return value;
  return std::nullopt;
}

std::vector<std::string> Args::all(std::string_view flag) const {
  const std::string_view name = spec(flag).name;
  std::vector<std::string> out;
  for (const auto& [key, value] : values_)
    if (key == name) out.push_back(value);
  return out;
}

std::size_t Args::count(std::string_view flag) const {
  return all(flag).size();
}

std::optional<double> Args::number(std::string_view flag) const {
  auto raw = text(flag);
  if (!raw) return std::nullopt;
  auto v = parse_double(*raw);
  if (!v) bad_value(flag, "a number", *raw);
  if (!std::isfinite(*v)) bad_value(flag, "a finite number", *raw);
  return v;
}

std::optional<double> Args::non_negative(std::string_view flag) const {
  auto raw = text(flag);
  if (!raw) return std::nullopt;
  auto v = parse_double(*raw);
  if (!v || !std::isfinite(*v) || *v < 0) bad_value(flag, "a non-negative number", *raw);
  return v;
}

std::optional<int> Args::positive_integer(std::string_view flag) const {
  auto raw = text(flag);
  if (!raw) return std::nullopt;
  auto v = parse_integer(*raw);
  if (!v || *v < 1 || *v > std::numeric_limits<int>::max()) bad_value(flag, "a positive integer", *raw);
  return static_cast<int>(*v);
}

std::optional<unsigned> Args::non_negative_integer(std::string_view flag) const {
  auto raw = text(flag);
  if (!raw) return std::nullopt;
  auto v = parse_integer(*raw);
  if (!v || *v < 0 || *v > std::numeric_limits<int>::max()) bad_value(flag, "a non-negative integer", *raw);
  return static_cast<unsigned>(*v);
}

std::optional<std::pair<double, double>> Args::pair(std::string_view flag) const {
  auto raw = text(flag);
  if (!raw) return std::nullopt;
  const std::string_view s = *raw;
  const auto comma = s.find(',');
  if (comma == std::string_view::npos || s.find(',', comma + 1) != std::string_view::npos)
    bad_value(flag, "X,Y (two numbers separated by a comma)", s);
  auto a = parse_double(trim(s.substr(0, comma)));
  auto b = parse_double(trim(s.substr(comma + 1)));
  if (!a || !b) bad_value(flag, "X,Y (two numbers separated by a comma)", s);
  if (!std::isfinite(*a) || !std::isfinite(*b)) bad_value(flag, "two finite numbers X,Y", s);
  return std::pair{*a, *b};
}

std::optional<std::string> Args::choice(std::string_view flag, std::span<const std::string_view> allowed) const {
  auto raw = text(flag);
  if (!raw) return std::nullopt;
  if (std::find(allowed.begin(), allowed.end(), *raw) != allowed.end()) return raw;
  std::string options;
  for (std::string_view a : allowed) {
    if (!options.empty()) options += ", ";
    options += a;
  }
  bad_value(flag, "one of " + options, *raw);
}

std::string format_flag_table(std::span<const FlagSpec> specs) {
  std::vector<std::string> heads;
  std::size_t width = 0;
  for (const FlagSpec& s : specs) {
    std::string head = "  ";
    if (!s.alias.empty()) {
      head += s.alias;
      head += ", ";
    }
    head += s.name;
    if (!s.value.empty()) {
      head += ' ';
      head += s.value;
    }
    width = std::max(width, head.size());
    heads.push_back(std::move(head));
  }
  std::string out;
  for (std::size_t i = 0; i < specs.size(); ++i) {
    out += heads[i];
    out.append(width + 2 - heads[i].size(), ' ');
    out += specs[i].help;
    out += '\n';
  }
  return out;
}

}  // namespace horizon::cli
