#include "mesh/ply_reader.hpp"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <sstream>

namespace horizon::mesh::detail {
namespace {

enum class Scalar { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

struct ScalarName {
  const char* name;
  Scalar type;
};
constexpr ScalarName kScalars[] = {
    {"char", Scalar::kInt8},     {"int8", Scalar::kInt8},       {"uchar", Scalar::kUint8},
    {"uint8", Scalar::kUint8},   {"short", Scalar::kInt16},     {"int16", Scalar::kInt16},
    {"ushort", Scalar::kUint16}, {"uint16", Scalar::kUint16},   {"int", Scalar::kInt32},
    {"int32", Scalar::kInt32},   {"uint", Scalar::kUint32},     {"uint32", Scalar::kUint32},
    {"float", Scalar::kFloat32}, {"float32", Scalar::kFloat32}, {"double", Scalar::kFloat64},
    {"float64", Scalar::kFloat64},
};

std::optional<Scalar> scalar_named(const std::string& name) {
  for (const ScalarName& s : kScalars)
    if (name == s.name) return s.type;
  return std::nullopt;
}

std::size_t size_of(Scalar type) {
  switch (type) {
    case Scalar::kInt8: case Scalar::kUint8: return 1;
    case Scalar::kInt16: case Scalar::kUint16: return 2;
    case Scalar::kInt32: case Scalar::kUint32: case Scalar::kFloat32: return 4;
    case Scalar::kFloat64: return 8;
  }
  return 8;
}

bool integral(Scalar type) { return type != Scalar::kFloat32 && type != Scalar::kFloat64; }

enum class Format { kAscii, kLittleEndian, kBigEndian };

struct Property {
  std::string name;
  Scalar type = Scalar::kFloat64;  // the items' type, for a list
  bool list = false;
  Scalar count_type = Scalar::kUint8;
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::size_t line = 0;  // where the header declares it
  std::vector<Property> properties;

  // The fewest bytes one item can take: a list may be empty; a text
  // scalar is one character at least.
  std::uint64_t min_item_bytes(Format format) const {
    std::uint64_t bytes = 0;
    for (const Property& p : properties)
      bytes += format == Format::kAscii ? 1 : size_of(p.list ? p.count_type : p.type);
    return std::max<std::uint64_t>(bytes, 1);
  }
};

struct Header {
  Format format = Format::kAscii;
  std::vector<Element> elements;
  std::size_t body = 0;  // offset of the first byte after end_header's line
};

// The data after the header, scalar by scalar.
class Body {
 public:
  Body(const std::string& bytes, std::size_t offset, Format format) : bytes_(bytes), at_(offset), format_(format) {}

  std::uint64_t remaining() const { return bytes_.size() - at_; }

  // One scalar as a double (every PLY scalar is exact in one). nullopt at
  // the end of the data or on a text token that is not a number.
  std::optional<double> read(Scalar type) {
    if (format_ == Format::kAscii) return read_text();
    const std::size_t n = size_of(type);
    if (remaining() < n) return std::nullopt;
    unsigned char raw[8];
    std::memcpy(raw, bytes_.data() + at_, n);
    at_ += n;
    const bool little = format_ == Format::kLittleEndian;
    if (little != (std::endian::native == std::endian::little)) std::reverse(raw, raw + n);
    return decode(type, raw);
  }

  // What is left after the last element: whitespace only, for text.
  bool only_padding_left() const {
    if (format_ != Format::kAscii) return remaining() == 0;
    return std::all_of(bytes_.begin() + static_cast<std::ptrdiff_t>(at_), bytes_.end(),
                       [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; });
  }

 private:
  std::optional<double> read_text() {
    while (at_ < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[at_]))) ++at_;
    std::size_t end = at_;
    while (end < bytes_.size() && !std::isspace(static_cast<unsigned char>(bytes_[end]))) ++end;
    if (end == at_) return std::nullopt;
    double value = 0.0;
    const char* first = bytes_.data() + at_;
    const char* last = bytes_.data() + end;
    if (*first == '+') ++first;  // from_chars takes no plus sign
    const auto [ptr, ec] = std::from_chars(first, last, value);
    if (ec != std::errc() || ptr != last) return std::nullopt;
    at_ = end;
    return value;
  }

  static double decode(Scalar type, const unsigned char* raw) {
    switch (type) {
      case Scalar::kInt8: return static_cast<std::int8_t>(raw[0]);
      case Scalar::kUint8: return raw[0];
      case Scalar::kInt16: return as<std::int16_t>(raw);
      case Scalar::kUint16: return as<std::uint16_t>(raw);
      case Scalar::kInt32: return as<std::int32_t>(raw);
      case Scalar::kUint32: return as<std::uint32_t>(raw);
      case Scalar::kFloat32: return as<float>(raw);
      case Scalar::kFloat64: return as<double>(raw);
    }
    return 0.0;
  }
  template <class T>
  static double as(const unsigned char* raw) {
    T value;
    std::memcpy(&value, raw, sizeof(T));
    return static_cast<double>(value);
  }

  const std::string& bytes_;
  std::size_t at_;
  Format format_;
};

class Reader {
 public:
  Reader(const std::string& bytes, const std::string& name) : bytes_(bytes), name_(name) {}

  Result<PolygonSoup> read() {
    auto header = read_header();
    if (!header.ok()) return header.error();
    HORIZON_RETURN_IF_ERROR(check_elements(*header));
    Body body(bytes_, header->body, header->format);
    PolygonSoup soup;
    for (const Element& element : header->elements) {
      // Every count was bounded by the bytes left when the header was
      // read; a list's length is bounded the same way below.
      if (element.count > body.remaining() / element.min_item_bytes(header->format))
        return refuse("element " + element.name + " claims " + std::to_string(element.count) +
                      " items, more than the file's remaining " + std::to_string(body.remaining()) + " bytes hold");
      HORIZON_RETURN_IF_ERROR(read_element(element, header->format, body, soup));
    }
    if (!body.only_padding_left())
      return refuse(std::to_string(body.remaining()) +
                    " bytes follow the last element: the header's counts do not match the data");
    return soup;
  }

 private:
  Error refuse(const std::string& why) const {
    return make_error(ErrorCode::kDataError, name_ + ": PLY " + why, "mesh");
  }
  Error refuse_line(std::size_t line, const std::string& why) const {
    return refuse("header line " + std::to_string(line) + ": " + why);
  }

  Result<Header> read_header() const {
    Header header;
    std::size_t at = 0;
    for (std::size_t number = 1;; ++number) {
      if (number > 10'000) return refuse_line(number, "no end_header in the first 10 000 lines");
      const std::size_t end = bytes_.find('\n', at);
      if (end == std::string::npos) return refuse("header has no end_header line");
      std::string line = bytes_.substr(at, end - at);
      at = end + 1;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      std::istringstream words(line);
      std::string keyword;
      words >> keyword;
      if (number == 1) {
        if (line != "ply") return refuse_line(1, "a PLY file starts with a line 'ply'");
        continue;
      }
      if (number == 2) {
        std::string format, version, extra;
        words >> format >> version >> extra;
        if (keyword != "format" || version != "1.0" || !extra.empty()) {
          return refuse_line(2, "expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
        }
        if (format == "ascii") header.format = Format::kAscii;
        else if (format == "binary_little_endian") header.format = Format::kLittleEndian;
        else if (format == "binary_big_endian") header.format = Format::kBigEndian;
        else return refuse_line(2, "unknown format '" + format + "'");
        continue;
      }
      if (keyword.empty() || keyword == "comment" || keyword == "obj_info") continue;
      if (keyword == "end_header") {
        header.body = at;
        return header;
      }
      if (keyword == "element") {
        Element element;
        std::string count;
        words >> element.name >> count;
        const auto [ptr, ec] = std::from_chars(count.data(), count.data() + count.size(), element.count);
        if (element.name.empty() || count.empty() || ec != std::errc() || ptr != count.data() + count.size())
          return refuse_line(number, "an element needs a name and a whole-number count");
        element.line = number;
        header.elements.push_back(std::move(element));
        continue;
      }
      if (keyword == "property") {
        if (header.elements.empty()) return refuse_line(number, "a property before any element");
        Property property;
        std::string type;
        words >> type;
        if (type == "list") {
          std::string count_type;
          words >> count_type >> type;
          const auto counted = scalar_named(count_type);
          if (!counted || !integral(*counted))
            return refuse_line(number, "a list's length type must be an integer type, not '" + count_type + "'");
          property.list = true;
          property.count_type = *counted;
        }
        const auto scalar = scalar_named(type);
        if (!scalar) return refuse_line(number, "unknown property type '" + type + "'");
        property.type = *scalar;
        words >> property.name;
        if (property.name.empty()) return refuse_line(number, "a property needs a name");
        header.elements.back().properties.push_back(std::move(property));
        continue;
      }
      return refuse_line(number, "unknown keyword '" + keyword + "'");
    }
  }

  // What a TIN needs of the header: one vertex element with x, y, z; at
  // most one face element, with a list of integral vertex indices.
  Status check_elements(const Header& header) const {
    bool vertex = false, face = false;
    for (const Element& element : header.elements) {
      if (element.name == "vertex") {
        if (vertex) return refuse_line(element.line, "a second vertex element");
        vertex = true;
        for (const char* axis : {"x", "y", "z"}) {
          const Property* p = find(element, {axis});
          if (!p) return refuse_line(element.line, std::string("the vertex element has no property ") + axis);
          if (p->list) return refuse_line(element.line, std::string("vertex property ") + axis + " is a list");
        }
      } else if (element.name == "face") {
        if (face) return refuse_line(element.line, "a second face element");
        face = true;
        const Property* p = find(element, {"vertex_indices", "vertex_index"});
        if (!p || !p->list)
          return refuse_line(element.line, "the face element has no list property vertex_indices");
        if (!integral(p->type)) return refuse_line(element.line, "face vertex indices must be an integer type");
      }
    }
    if (!vertex) return refuse("header declares no vertex element");
    return Status::Ok();
  }

  static const Property* find(const Element& element, std::initializer_list<const char*> names) {
    for (const Property& p : element.properties)
      for (const char* n : names)
        if (p.name == n) return &p;
    return nullptr;
  }

  Status read_element(const Element& element, Format format, Body& body, PolygonSoup& soup) const {
    const bool vertex = element.name == "vertex";
    const bool face = element.name == "face";
    if (vertex) soup.points.reserve(element.count);
    if (face) soup.faces.reserve(element.count);
    for (std::uint64_t item = 0; item < element.count; ++item) {
      std::array<double, 3> point{};
      std::vector<std::uint64_t> corners;
      for (const Property& p : element.properties) {
        auto where = [&] { return element.name + " " + std::to_string(item) + " (property " + p.name + ")"; };
        if (!p.list) {
          const auto value = body.read(p.type);
          if (!value) return refuse("ends or has a non-number inside " + where());
          if (vertex && p.name.size() == 1 && p.name[0] >= 'x' && p.name[0] <= 'z') point[p.name[0] - 'x'] = *value;
          continue;
        }
        const auto length = body.read(p.count_type);
        if (!length) return refuse("ends or has a non-number inside " + where());
        const std::uint64_t item_bytes = format == Format::kAscii ? 1 : size_of(p.type);
        if (*length < 0 || *length != std::floor(*length) ||
            *length > static_cast<double>(body.remaining() / item_bytes))
          return refuse(where() + ": a list of " + number_text(*length, 12) + " items, more than the file holds");
        const bool indices = face && (p.name == "vertex_indices" || p.name == "vertex_index");
        if (indices) corners.reserve(static_cast<std::size_t>(*length));
        for (std::uint64_t i = 0; i < static_cast<std::uint64_t>(*length); ++i) {
          const auto value = body.read(p.type);
          if (!value) return refuse("ends or has a non-number inside " + where());
          if (!indices) continue;
          if (!(*value >= 0 && *value <= 4294967295.0) || *value != std::floor(*value))
            return refuse(where() + ": vertex index " + number_text(*value, 12) +
                          " is not a whole number from 0 to 4294967295");
          corners.push_back(static_cast<std::uint64_t>(*value));
        }
      }
      if (vertex) soup.points.push_back(point);
      if (face) soup.faces.push_back(std::move(corners));
    }
    return Status::Ok();
  }

  const std::string& bytes_;
  const std::string& name_;
};

}  // namespace

Result<PolygonSoup> read_ply(const std::string& bytes, const std::string& name) {
  return Reader(bytes, name).read();
}

}  // namespace horizon::mesh::detail
