// Private to the engine: std::floor and std::ceil of a double as an int,
// for |x| < 2^31, without the library call that baseline x86-64 (no SSE4.1
// roundsd) makes for them: the same ints, by a truncation and a compare.
// Hot per-crossing and per-cell arithmetic (visibility/crossings.hpp, the
// sweep's geometry) goes through these.
#pragma once

namespace horizon {

inline int floor_to_int(double x) {
  const int i = static_cast<int>(x);
  return i - (x < i);
}

inline int ceil_to_int(double x) {
  const int i = static_cast<int>(x);
  return i + (x > i);
}

}  // namespace horizon
