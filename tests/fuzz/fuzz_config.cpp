// libFuzzer target: horizond's configuration parser on arbitrary text. Every
// document must parse to a Config or an Error naming a key; never a crash,
// an exception or an unbounded allocation.
#include <cstddef>
#include <cstdint>
#include <string>

#include "config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto config = horizon::server::parse_config(text, "fuzz.json", "/nonexistent-fuzz-base");
  if (config.ok()) (void)horizon::server::keys_needing_restart(*config, *config);
  return 0;
}
