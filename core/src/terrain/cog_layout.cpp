// The COG layout rewrite (cog_layout.hpp). TIFF 6.0 sections 2 (structure)
// and 15 (tiles); BigTIFF (libtiff's 2007 design note: header 43, 8-byte
// counts and offsets, 20-byte entries); GDAL's COG layout
// (https://gdal.org/drivers/raster/cog.html, "File format details").
#include "cog_layout.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <vector>

namespace horizon::terrain::detail {
namespace {

constexpr std::uint16_t kTileOffsets = 324, kTileByteCounts = 325, kStripOffsets = 273;
constexpr std::uint16_t kSubIfds = 330, kExifIfd = 34665, kGpsIfd = 34853;

// GDAL's structural metadata: its size line counts the bytes after itself.
std::string ghost_header() {
  const std::string body =
      "LAYOUT=IFDS_BEFORE_DATA\n"
      "BLOCK_ORDER=ROW_MAJOR\n"
      "BLOCK_LEADER=SIZE_AS_UINT4\n"
      "BLOCK_TRAILER=LAST_4_BYTES_REPEATED\n"
      "KNOWN_INCOMPATIBLE_EDITION=NO\n"
      " ";
  char head[64];
  std::snprintf(head, sizeof head, "GDAL_STRUCTURAL_METADATA_SIZE=%06zu bytes\n", body.size());
  return head + body;
}

// Bytes of one value of a TIFF field type; 0 for an unknown type.
std::uint64_t type_size(std::uint16_t type) {
  switch (type) {
    case 1: case 2: case 6: case 7:  // BYTE ASCII SBYTE UNDEFINED
      return 1;
    case 3: case 8:  // SHORT SSHORT
      return 2;
    case 4: case 9: case 11: case 13:  // LONG SLONG FLOAT IFD
      return 4;
    case 5: case 10: case 12: case 16: case 17: case 18:  // RATIONAL SRATIONAL DOUBLE LONG8 SLONG8 IFD8
      return 8;
    default:
      return 0;
  }
}

std::uint64_t get(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

void put(std::uint8_t* p, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}

struct Entry {
  std::uint16_t tag = 0, type = 0;
  std::uint64_t count = 0;
  std::vector<std::uint8_t> value;  // count * type_size bytes
  std::uint64_t new_offset = 0;     // where the value goes when it does not fit in the entry
};

struct Ifd {
  std::vector<Entry> entries;
  std::vector<std::uint64_t> tile_offsets, tile_counts;  // as read
  std::vector<std::uint64_t> new_tile_offsets;
  std::uint64_t new_offset = 0;
};

class Reader {
 public:
  Reader(int fd, const std::string& target) : fd_(fd), target_(target) {}
  Status read(std::uint64_t offset, void* into, std::uint64_t size) const {
    auto* p = static_cast<std::uint8_t*>(into);
    while (size > 0) {
      const ssize_t n = ::pread(fd_, p, size, static_cast<off_t>(offset));
      if (n <= 0) return fail(n < 0 ? std::strerror(errno) : "the file ends early");
      p += n;
      offset += static_cast<std::uint64_t>(n);
      size -= static_cast<std::uint64_t>(n);
    }
    return Status::Ok();
  }
  Error fail(const std::string& what) const {
    return make_error(ErrorCode::kInternal, "geotiff '" + target_ + "': cannot lay out the COG: " + what, target_);
  }

 private:
  int fd_;
  std::string target_;
};

std::vector<std::uint64_t> values_of(const Entry& e) {
  const std::uint64_t size = type_size(e.type);
  std::vector<std::uint64_t> out(e.count);
  for (std::uint64_t i = 0; i < e.count; ++i) out[i] = get(e.value.data() + i * size, static_cast<int>(size));
  return out;
}

struct FdCloser {
  void operator()(int* fd) const {
    if (*fd >= 0) ::close(*fd);
    delete fd;
  }
};

}  // namespace

Status write_cog_layout(const std::string& in, const std::string& out, const std::string& target) {
  std::unique_ptr<int, FdCloser> fd(new int(::open(in.c_str(), O_RDONLY | O_CLOEXEC)));
  Reader reader(*fd, target);
  if (*fd < 0) return reader.fail(std::string("cannot open the tiled copy: ") + std::strerror(errno));

  // Header: byte order, version, first IFD.
  std::uint8_t head[16];
  HORIZON_RETURN_IF_ERROR(reader.read(0, head, 8));
  if (head[0] != 'I' || head[1] != 'I') return reader.fail("not a little-endian TIFF");
  const std::uint64_t version = get(head + 2, 2);
  if (version != 42 && version != 43) return reader.fail("not a TIFF (version " + std::to_string(version) + ")");
  const bool big = version == 43;
  const int word = big ? 8 : 4;                   // offsets and inline values
  const std::uint64_t entry_size = big ? 20 : 12;
  const std::uint64_t count_size = big ? 8 : 2;   // the entry count before the entries
  std::uint64_t next = 0;
  if (big) {
    HORIZON_RETURN_IF_ERROR(reader.read(8, head + 8, 8));
    next = get(head + 8, 8);
  } else {
    next = get(head + 4, 4);
  }

  // Every IFD, its values read whole.
  std::vector<Ifd> ifds;
  while (next != 0) {
    if (ifds.size() > 64) return reader.fail("more than 64 images");
    std::uint8_t count_bytes[8];
    HORIZON_RETURN_IF_ERROR(reader.read(next, count_bytes, count_size));
    const std::uint64_t n = get(count_bytes, static_cast<int>(count_size));
    if (n == 0 || n > 4096) return reader.fail("an image file directory of " + std::to_string(n) + " entries");
    std::vector<std::uint8_t> raw(n * entry_size + word);
    HORIZON_RETURN_IF_ERROR(reader.read(next + count_size, raw.data(), raw.size()));
    Ifd ifd;
    for (std::uint64_t i = 0; i < n; ++i) {
      const std::uint8_t* p = raw.data() + i * entry_size;
      Entry e;
      e.tag = static_cast<std::uint16_t>(get(p, 2));
      e.type = static_cast<std::uint16_t>(get(p + 2, 2));
      e.count = get(p + 4, big ? 8 : 4);
      const std::uint8_t* field = p + (big ? 12 : 8);
      const std::uint64_t size = type_size(e.type);
      if (size == 0) return reader.fail("tag " + std::to_string(e.tag) + " has an unknown type");
      if (e.type == 13 || e.type == 18 || e.tag == kSubIfds || e.tag == kExifIfd || e.tag == kGpsIfd)
        return reader.fail("tag " + std::to_string(e.tag) + " points at other directories");
      if (e.tag == kStripOffsets) return reader.fail("the image is in strips; a COG is tiled");
      if (e.count > (std::uint64_t{1} << 32) / size) return reader.fail("tag " + std::to_string(e.tag) + " is too long");
      e.value.resize(e.count * size);
      if (e.value.size() <= static_cast<std::size_t>(word))
        std::memcpy(e.value.data(), field, e.value.size());
      else
        HORIZON_RETURN_IF_ERROR(reader.read(get(field, word), e.value.data(), e.value.size()));
      if (e.tag == kTileOffsets) ifd.tile_offsets = values_of(e);
      if (e.tag == kTileByteCounts) ifd.tile_counts = values_of(e);
      ifd.entries.push_back(std::move(e));
    }
    if (ifd.tile_offsets.empty() || ifd.tile_offsets.size() != ifd.tile_counts.size())
      return reader.fail("an image without tile offsets and byte counts");
    next = get(raw.data() + n * entry_size, word);
    ifds.push_back(std::move(ifd));
  }
  if (ifds.empty()) return reader.fail("no image");

  // The new layout: header, ghost, the IFDs with their values, then the tiles.
  const std::string ghost = ghost_header();
  const auto even = [](std::uint64_t v) { return v + (v & 1); };
  std::uint64_t pos = even((big ? 16 : 8) + ghost.size());
  for (Ifd& ifd : ifds) {
    ifd.new_offset = pos;
    pos += count_size + ifd.entries.size() * entry_size + word;
    for (Entry& e : ifd.entries)
      if (e.value.size() > static_cast<std::size_t>(word)) {
        pos = even(pos);
        e.new_offset = pos;
        pos += e.value.size();
      }
    pos = even(pos);
  }
  for (auto ifd = ifds.rbegin(); ifd != ifds.rend(); ++ifd) {
    ifd->new_tile_offsets.assign(ifd->tile_offsets.size(), 0);
    for (std::size_t t = 0; t < ifd->tile_offsets.size(); ++t) {
      if (ifd->tile_counts[t] == 0) continue;  // a sparse tile stays at offset 0
      pos += 4;                                // the leader
      ifd->new_tile_offsets[t] = pos;
      pos += ifd->tile_counts[t] + 4;  // the tile and its trailer
    }
  }
  if (!big && pos > std::numeric_limits<std::uint32_t>::max())
    return reader.fail("the file outgrows classic TIFF's 4 GiB; write it with BIGTIFF=YES");
  for (Ifd& ifd : ifds)
    for (Entry& e : ifd.entries)
      if (e.tag == kTileOffsets) {
        const std::uint64_t size = type_size(e.type);
        for (std::size_t t = 0; t < ifd.new_tile_offsets.size(); ++t) {
          if (size < 8 && ifd.new_tile_offsets[t] >> (8 * size) != 0)
            return reader.fail("a tile offset outgrows its field");
          put(e.value.data() + t * size, ifd.new_tile_offsets[t], static_cast<int>(size));
        }
      }

  // Written front to back, in the order laid out above.
  std::FILE* file = std::fopen(out.c_str(), "wb");
  if (!file) return reader.fail("cannot open '" + out + "': " + std::strerror(errno));
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> closer(file, std::fclose);
  std::uint64_t written = 0;
  const auto emit = [&](const void* p, std::uint64_t n) {
    if (n && std::fwrite(p, 1, n, file) != n) return false;
    written += n;
    return true;
  };
  const auto pad_to = [&](std::uint64_t at) {
    static const std::uint8_t zeros[8] = {};
    return at >= written && emit(zeros, at - written);
  };
  std::uint8_t header[16] = {'I', 'I'};
  put(header + 2, version, 2);
  if (big) {
    put(header + 4, 8, 2);
    put(header + 8, ifds.front().new_offset, 8);
  } else {
    put(header + 4, ifds.front().new_offset, 4);
  }
  bool ok = emit(header, big ? 16 : 8) && emit(ghost.data(), ghost.size());
  for (std::size_t i = 0; ok && i < ifds.size(); ++i) {
    const Ifd& ifd = ifds[i];
    std::vector<std::uint8_t> block(count_size + ifd.entries.size() * entry_size + word, 0);
    put(block.data(), ifd.entries.size(), static_cast<int>(count_size));
    for (std::size_t k = 0; k < ifd.entries.size(); ++k) {
      const Entry& e = ifd.entries[k];
      std::uint8_t* p = block.data() + count_size + k * entry_size;
      put(p, e.tag, 2);
      put(p + 2, e.type, 2);
      put(p + 4, e.count, big ? 8 : 4);
      std::uint8_t* field = p + (big ? 12 : 8);
      if (e.value.size() <= static_cast<std::size_t>(word))
        std::memcpy(field, e.value.data(), e.value.size());
      else
        put(field, e.new_offset, word);
    }
    put(block.data() + count_size + ifd.entries.size() * entry_size, i + 1 < ifds.size() ? ifds[i + 1].new_offset : 0,
        word);
    ok = pad_to(ifd.new_offset) && emit(block.data(), block.size());
    for (const Entry& e : ifd.entries)
      if (ok && e.value.size() > static_cast<std::size_t>(word))
        ok = pad_to(e.new_offset) && emit(e.value.data(), e.value.size());
  }
  std::vector<std::uint8_t> tile;
  for (auto ifd = ifds.rbegin(); ok && ifd != ifds.rend(); ++ifd)
    for (std::size_t t = 0; ok && t < ifd->tile_offsets.size(); ++t) {
      const std::uint64_t n = ifd->tile_counts[t];
      if (n == 0) continue;
      tile.assign(n, 0);
      HORIZON_RETURN_IF_ERROR(reader.read(ifd->tile_offsets[t], tile.data(), n));
      std::uint8_t leader[4], trailer[4] = {};
      put(leader, n, 4);
      const std::uint64_t tail = std::min<std::uint64_t>(4, n);
      std::memcpy(trailer + (4 - tail), tile.data() + (n - tail), tail);
      ok = pad_to(ifd->new_tile_offsets[t] - 4) && emit(leader, 4) && emit(tile.data(), n) && emit(trailer, 4);
    }
  if (!ok || std::fflush(file) != 0) return reader.fail("cannot write '" + out + "': " + std::strerror(errno));
  if (std::fclose(closer.release()) != 0) return reader.fail("cannot close '" + out + "': " + std::strerror(errno));
  return Status::Ok();
}

}  // namespace horizon::terrain::detail
