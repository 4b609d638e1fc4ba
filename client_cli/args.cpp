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

[[noreturn]] void bad_value(const std::string& flag, std::string_view expected, std::string_view got) {
  throw UsageError(flag + ": expected " + std::string(expected) + ", got '" + std::string(got) + "'");
}

// The space-separated short forms of a spec ("-f -of" -> "-f", "-of").
std::vector<std::string_view> aliases_of(const FlagSpec& spec) {
  std::vector<std::string_view> out;
  std::string_view rest = spec.alias;
  while (!rest.empty()) {
    const auto space = rest.find(' ');
    const std::string_view one = rest.substr(0, space);
    if (!one.empty()) out.push_back(one);
    if (space == std::string_view::npos) break;
    rest.remove_prefix(space + 1);
  }
  return out;
}

const FlagSpec* find_spec(std::span<const FlagSpec> specs, std::string_view token) {
  for (const FlagSpec& s : specs) {
    if (s.name == token) return &s;
    for (std::string_view a : aliases_of(s))
      if (a == token) return &s;
  }
  return nullptr;
}

// Levenshtein distance, case-sensitive (flags are lower case).
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
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
    if (!spec) {
      const std::string near = nearest_flag(name, specs);
      throw UsageError("unknown flag '" + std::string(name) + "'" +
                       (near.empty() ? std::string() : "; did you mean '" + near + "'?"));
    }
    const std::string typed(name);
    const auto earlier = std::find_if(args.values_.begin(), args.values_.end(),
                                      [&](const Given& given) { return given.name == spec->name; });
    if (earlier != args.values_.end() && !spec->repeatable)
      throw UsageError(typed + ": given more than once" +
                       (earlier->typed == typed ? std::string() : " (also as " + earlier->typed + ")"));

    if (spec->value.empty()) {
      if (inline_value) throw UsageError(typed + ": takes no value, got '" + *inline_value + "'");
      args.values_.push_back({spec->name, std::string(), typed});
      continue;
    }
    if (!inline_value) {
      if (i + 1 >= argv.size())
        throw UsageError(typed + ": missing value (expected " + std::string(spec->value) + ")");
      inline_value = argv[++i];
    }
    args.values_.push_back({spec->name, std::move(*inline_value), typed});
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
  for (const Given& given : values_)
    if (given.name == name) return given.value;
  return std::nullopt;
}

std::vector<std::string> Args::all(std::string_view flag) const {
  const std::string_view name = spec(flag).name;
  std::vector<std::string> out;
  for (const Given& given : values_)
    if (given.name == name) out.push_back(given.value);
  return out;
}

std::string Args::typed(std::string_view flag) const {
  const FlagSpec* s = find_spec(specs_, flag);
  if (!s) return std::string(flag);
  for (const Given& given : values_)
    if (given.name == s->name) return given.typed;
  return std::string(s->name);
}

std::size_t Args::count(std::string_view flag) const {
  return all(flag).size();
}

std::optional<double> Args::number(std::string_view flag) const {
  auto raw = text(flag);
  if (!raw) return std::nullopt;
  auto v = parse_double(*raw);
  if (!v) bad_value(typed(flag), "a number", *raw);
  if (!std::isfinite(*v)) bad_value(typed(flag), "a finite number", *raw);
  return v;
}

std::optional<double> Args::non_negative(std::string_view flag) const {
  auto raw = text(flag);
  if (!raw) return std::nullopt;
  auto v = parse_double(*raw);
  if (!v || !std::isfinite(*v) || *v < 0) bad_value(typed(flag), "a non-negative number", *raw);
  return v;
}

std::optional<int> Args::positive_integer(std::string_view flag) const {
  auto raw = text(flag);
  if (!raw) return std::nullopt;
  auto v = parse_integer(*raw);
  if (!v || *v < 1 || *v > std::numeric_limits<int>::max()) bad_value(typed(flag), "a positive integer", *raw);
  return static_cast<int>(*v);
}

std::optional<unsigned> Args::non_negative_integer(std::string_view flag) const {
  auto raw = text(flag);
  if (!raw) return std::nullopt;
  auto v = parse_integer(*raw);
  if (!v || *v < 0 || *v > std::numeric_limits<int>::max()) bad_value(typed(flag), "a non-negative integer", *raw);
  return static_cast<unsigned>(*v);
}

std::optional<std::pair<double, double>> Args::pair(std::string_view flag) const {
  auto raw = text(flag);
  if (!raw) return std::nullopt;
  const std::string_view s = *raw;
  // Said in the help's own shape: "X,Y", "START,END", "MIN,MAX".
  const std::string shape(spec(flag).value);
  const auto comma = s.find(',');
  if (comma == std::string_view::npos || s.find(',', comma + 1) != std::string_view::npos)
    bad_value(typed(flag), shape + " (two numbers separated by a comma)", s);
  auto a = parse_double(trim(s.substr(0, comma)));
  auto b = parse_double(trim(s.substr(comma + 1)));
  if (!a || !b) bad_value(typed(flag), shape + " (two numbers separated by a comma)", s);
  if (!std::isfinite(*a) || !std::isfinite(*b)) bad_value(typed(flag), "two finite numbers " + shape, s);
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
  bad_value(typed(flag), "one of " + options, *raw);
}

std::string format_flag_table(std::span<const FlagSpec> specs) {
  std::vector<std::string> heads;
  std::size_t width = 0;
  for (const FlagSpec& s : specs) {
    std::string head = "  ";
    for (std::string_view a : aliases_of(s)) {
      head += a;
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

std::string nearest_flag(std::string_view token, std::span<const FlagSpec> specs) {
  std::string_view best;
  std::size_t best_distance = std::numeric_limits<std::size_t>::max();
  auto consider = [&](std::string_view candidate) {
    const std::size_t d = edit_distance(token, candidate);
    if (d < best_distance) {
      best_distance = d;
      best = candidate;
    }
  };
  for (const FlagSpec& s : specs) {
    consider(s.name);
    for (std::string_view a : aliases_of(s)) consider(a);
  }
  // A typo is a few edits: two at most, and fewer than a third of the
  // longer word's letters past the dashes (so "-q" suggests nothing).
  const std::size_t letters = std::max(token.size(), best.size()) - std::min<std::size_t>(2, token.size());
  if (best.empty() || best_distance > 2 || 3 * best_distance > letters + 1) return {};
  return std::string(best);
}

}  // namespace horizon::cli
