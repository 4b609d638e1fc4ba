// geokeys.cpp — the GeoKey directory without libgeotiff (see geokeys.hpp).
#include "geokeys.hpp"

#include <algorithm>
#include <cstring>
#include <limits>
#include <utility>

#include "tiff_support.hpp"

namespace horizon::terrain::detail {
namespace {

constexpr ttag_t kDirectoryTag = kTagGeoKeyDirectory;  // SHORT
constexpr ttag_t kDoubleTag = kTagGeoDoubleParams;     // DOUBLE
constexpr ttag_t kAsciiTag = kTagGeoAsciiParams;       // ASCII

// A counted array tag's values. The count's C type depends on how the tag
// was registered (uint16 for TIFF_VARIABLE, uint32 for TIFF_VARIABLE2), so
// libtiff is asked rather than assumed.
template <class T>
std::vector<T> counted_values(TIFF* tif, ttag_t tag) {
  const TIFFField* field = TIFFFindField(tif, tag, TIFF_ANY);
  if (!field) return {};
  T* values = nullptr;
  std::uint32_t count = 0;
  if (TIFFFieldReadCount(field) == TIFF_VARIABLE2) {
    if (TIFFGetField(tif, tag, &count, &values) != 1) return {};
  } else {
    std::uint16_t count16 = 0;
    if (TIFFGetField(tif, tag, &count16, &values) != 1) return {};
    count = count16;
  }
  if (!values) return {};
  return std::vector<T>(values, values + count);
}

Error corrupt(const std::string& why) {
  return make_error(ErrorCode::kDataError, why);
}

}  // namespace

std::vector<double> tiff_doubles(TIFF* tif, ttag_t tag) {
  return counted_values<double>(tif, tag);
}

Result<GeoKeys> GeoKeys::read(TIFF* tif) {
  GeoKeys keys;
  const std::vector<std::uint16_t> dir = counted_values<std::uint16_t>(tif, kDirectoryTag);
  if (dir.empty()) return keys;
  if (dir.size() < 4) return corrupt(std::to_string(dir.size()) + " values, fewer than its 4-value header");
  if (dir[0] != 1) return corrupt("version " + std::to_string(dir[0]) + "; GeoTIFF defines version 1");
  keys.revision_ = dir[1];
  keys.minor_revision_ = dir[2];
  const std::size_t count = dir[3];
  if (4 + 4 * count > dir.size())
    return corrupt(std::to_string(count) + " keys claimed, " + std::to_string((dir.size() - 4) / 4) + " held");
  const std::vector<double> doubles = counted_values<double>(tif, kDoubleTag);
  const char* ascii_tag = nullptr;
  if (TIFFFindField(tif, kAsciiTag, TIFF_ANY) && TIFFGetField(tif, kAsciiTag, &ascii_tag) != 1) ascii_tag = nullptr;
  const std::size_t ascii_size = ascii_tag ? std::strlen(ascii_tag) : 0;

  for (std::size_t i = 0; i < count; ++i) {
    const std::uint16_t* e = &dir[4 + 4 * i];
    const int key = e[0];
    const std::size_t n = e[2], at = e[3];
    const std::string where = "GeoKey " + std::to_string(key);
    Value v;
    switch (e[1]) {
      case 0:  // the value is the entry's last field
        if (n != 1) return corrupt(where + " holds its value in its entry but counts " + std::to_string(n));
        v.type = Type::kShort;
        v.shorts = {e[3]};
        break;
      case kDirectoryTag:
        if (at + n > dir.size()) return corrupt(where + "'s values lie beyond its end");
        v.type = Type::kShort;
        v.shorts.assign(dir.begin() + static_cast<std::ptrdiff_t>(at),
                        dir.begin() + static_cast<std::ptrdiff_t>(at + n));
        break;
      case kDoubleTag:
        if (at + n > doubles.size()) return corrupt(where + "'s values lie beyond GeoDoubleParams");
        v.type = Type::kDouble;
        v.doubles.assign(doubles.begin() + static_cast<std::ptrdiff_t>(at),
                         doubles.begin() + static_cast<std::ptrdiff_t>(at + n));
        break;
      case kAsciiTag: {
        // libtiff keeps the string without the NUL a writer counted; a value
        // ending there, or running past the end, is cut at the end.
        if (!ascii_tag || at > ascii_size || (at == ascii_size && n > 1))
          return corrupt(where + "'s text lies beyond GeoAsciiParams");
        const std::size_t take = std::min(n, ascii_size - at);
        v.type = Type::kAscii;
        v.ascii.assign(ascii_tag + at, take);
        if (!v.ascii.empty() && v.ascii.back() == '|') v.ascii.pop_back();
        break;
      }
      default:
        return corrupt(where + " is stored in TIFF tag " + std::to_string(e[1]) +
                       ", none of GeoKeyDirectory, GeoDoubleParams or GeoAsciiParams");
    }
    keys.keys_[key] = std::move(v);
  }
  return keys;
}

std::optional<int> GeoKeys::short_value(int key) const {
  const auto it = keys_.find(key);
  if (it == keys_.end() || it->second.type != Type::kShort || it->second.shorts.empty()) return std::nullopt;
  return it->second.shorts.front();
}

std::optional<std::string> GeoKeys::ascii(int key) const {
  const auto it = keys_.find(key);
  if (it == keys_.end() || it->second.type != Type::kAscii) return std::nullopt;
  return it->second.ascii;
}

std::optional<std::vector<double>> GeoKeys::doubles(int key) const {
  const auto it = keys_.find(key);
  if (it == keys_.end() || it->second.type != Type::kDouble) return std::nullopt;
  return it->second.doubles;
}

void GeoKeys::set_short(int key, int value) {
  Value v;
  v.type = Type::kShort;
  v.shorts = {static_cast<std::uint16_t>(value)};
  keys_[key] = std::move(v);
}

void GeoKeys::set_doubles(int key, std::vector<double> values) {
  Value v;
  v.type = Type::kDouble;
  v.doubles = std::move(values);
  keys_[key] = std::move(v);
}

void GeoKeys::set_ascii(int key, std::string text) {
  Value v;
  v.type = Type::kAscii;
  v.ascii = std::move(text);
  keys_[key] = std::move(v);
}

void GeoKeys::set_revision(int major, int minor) {
  revision_ = major;
  minor_revision_ = minor;
}

bool GeoKeys::write(TIFF* tif) const {
  std::vector<std::uint16_t> dir = {1, static_cast<std::uint16_t>(revision_),
                                    static_cast<std::uint16_t>(minor_revision_),
                                    static_cast<std::uint16_t>(keys_.size())};
  std::vector<std::uint16_t> extra;  // SHORT values that do not fit their entry
  std::vector<double> doubles;
  std::string ascii;
  const std::size_t entries_end = 4 + 4 * keys_.size();
  for (const auto& [key, v] : keys_) {
    std::uint16_t location = 0, count = 1, offset = 0;
    std::size_t at = 0;
    switch (v.type) {
      case Type::kShort:
        if (v.shorts.empty() || v.shorts.size() > std::numeric_limits<std::uint16_t>::max()) return false;
        count = static_cast<std::uint16_t>(v.shorts.size());
        if (v.shorts.size() == 1) {
          offset = v.shorts.front();
        } else {
          location = static_cast<std::uint16_t>(kDirectoryTag);
          at = entries_end + extra.size();
          extra.insert(extra.end(), v.shorts.begin(), v.shorts.end());
        }
        break;
      case Type::kDouble:
        if (v.doubles.size() > std::numeric_limits<std::uint16_t>::max()) return false;
        location = static_cast<std::uint16_t>(kDoubleTag);
        count = static_cast<std::uint16_t>(v.doubles.size());
        at = doubles.size();
        doubles.insert(doubles.end(), v.doubles.begin(), v.doubles.end());
        break;
      case Type::kAscii:
        if (v.ascii.size() >= std::numeric_limits<std::uint16_t>::max()) return false;
        location = static_cast<std::uint16_t>(kAsciiTag);
        count = static_cast<std::uint16_t>(v.ascii.size() + 1);
        at = ascii.size();
        ascii += v.ascii;
        ascii += '|';
        break;
    }
    if (location != 0) {
      if (at > std::numeric_limits<std::uint16_t>::max()) return false;
      offset = static_cast<std::uint16_t>(at);
    }
    dir.insert(dir.end(), {static_cast<std::uint16_t>(key), location, count, offset});
  }
  dir.insert(dir.end(), extra.begin(), extra.end());
  if (dir.size() > std::numeric_limits<std::uint16_t>::max() ||
      doubles.size() > std::numeric_limits<std::uint16_t>::max())
    return false;
  if (TIFFSetField(tif, kDirectoryTag, static_cast<int>(dir.size()), dir.data()) != 1) return false;
  if (!doubles.empty() && TIFFSetField(tif, kDoubleTag, static_cast<int>(doubles.size()), doubles.data()) != 1)
    return false;
  if (!ascii.empty() && TIFFSetField(tif, kAsciiTag, ascii.c_str()) != 1) return false;
  return true;
}

}  // namespace horizon::terrain::detail
