// Elevation sources: one file, or a mosaic of files on one grid, read window
// by window, directly or through the shared block cache.
#include "horizon/terrain/source.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cassert>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <mutex>
#include <optional>
#include <string>
#include <utility>

#include "horizon/common/parallel.hpp"
#include "horizon/geodesy/crs.hpp"

namespace horizon::terrain {
namespace {

Error source_error(ErrorCode code, const std::string& path, const std::string& what) {
  return make_error(code, "dem '" + path + "': " + what, path);
}

bool is_raster_name(const std::filesystem::path& p) {
  std::string ext = p.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".tif" || ext == ".tiff" || ext == ".hgt";
}

Window shifted(const Window& w, int dc, int dr) {
  return {w.col0 + dc, w.row0 + dr, w.col1 + dc, w.row1 + dr};
}

// `value` as an integer when it is one to within 1e-6.
std::optional<long long> whole(double value) {
  const double r = std::round(value);
  if (std::abs(value - r) > 1e-6 || std::abs(r) > 1e9) return std::nullopt;
  return static_cast<long long>(r);
}

// The source's blocks of a file: its own tiles or strips, grouped (doubling
// the narrower side) until a block holds about `target` cells; a file
// whose one block reads row by row (an .hgt) is cut into bands of rows. A
// TIFF of one strip stays one block: each band would decode the whole strip.
void lay_out_blocks(SourceFile& f, std::uint64_t target) {
  const DemHeader& h = f.raster->header();
  int bw = h.block_width, bh = h.block_height;
  if (h.blocks_total <= 1 && h.rows_read_alone) {
    bw = h.width;
    bh = static_cast<int>(std::clamp<std::uint64_t>(target / static_cast<std::uint64_t>(h.width), 1,
                                                    static_cast<std::uint64_t>(h.height)));
  }
  bw = std::max(1, std::min(bw, h.width));
  bh = std::max(1, std::min(bh, h.height));
  while (static_cast<std::uint64_t>(bw) * static_cast<std::uint64_t>(bh) < target) {
    if ((bw <= bh || bh >= h.height) && bw < h.width)
      bw = std::min(2 * bw, h.width);
    else if (bh < h.height)
      bh = std::min(2 * bh, h.height);
    else
      break;
  }
  f.block_width = bw;
  f.block_height = bh;
  // In 64 bits: a width and a block width near 2^31 overflow an int.
  f.blocks_x = static_cast<int>((std::int64_t{h.width} + bw - 1) / bw);
  f.blocks_y = static_cast<int>((std::int64_t{h.height} + bh - 1) / bh);
}

std::string describe_cells(const Window& w) {
  return "cols " + std::to_string(w.col0) + ".." + std::to_string(w.col1 - 1) + ", rows " + std::to_string(w.row0) +
         ".." + std::to_string(w.row1 - 1);
}

// Whether every cell of a row lies in [lo, hi] or is a void (NaN). No early
// exit and no short-circuit, so the compiler turns it into vector compares.
bool row_plausible(const float* row, int n, float lo, float hi) {
  unsigned char outside = 0;
  for (int c = 0; c < n; ++c) outside |= static_cast<unsigned char>((row[c] < lo) | (row[c] > hi));
  return outside == 0;
}

// Cells outside the plausible range (NaN passes), as an error naming `file`
// and where the first such cell lies; `at` places `cells` in the source's
// grid. When the reader's value range (`read`) lies inside the plausible
// one, no cell can be outside it and none is looked at; otherwise rows are
// checked on `threads` threads (a whole DEM read at once is tens of millions
// of cells).
Status check_plausible(const Grid<float>& cells, const ReadStats& read, const Window& at, const SourceOptions& o,
                       const std::string& file, const std::string& where, unsigned threads = 1) {
  const float lo = static_cast<float>(o.valid_min), hi = static_cast<float>(o.valid_max);
  if (read.value_min >= lo && read.value_max <= hi) return Status::Ok();
  constexpr int kRowsPerTask = 64;
  const std::size_t tasks = (static_cast<std::size_t>(cells.height()) + kRowsPerTask - 1) / kRowsPerTask;
  std::vector<unsigned char> bad(tasks, 0);
  parallel_for(tasks, tasks > 1 ? threads : 1, [&](std::size_t t) {
    const int r1 = std::min(cells.height(), static_cast<int>(t + 1) * kRowsPerTask);
    for (int r = static_cast<int>(t) * kRowsPerTask; r < r1 && !bad[t]; ++r)
      bad[t] = !row_plausible(cells.row(r), cells.width(), lo, hi);
  });
  const auto first = std::find(bad.begin(), bad.end(), 1);
  if (first == bad.end()) return Status::Ok();
  for (int r = static_cast<int>(first - bad.begin()) * kRowsPerTask; r < cells.height(); ++r) {
    const float* row = cells.row(r);
    for (int c = 0; c < cells.width(); ++c) {
      if (!(row[c] < lo || row[c] > hi)) continue;  // in range, or a void
      return source_error(ErrorCode::kDataError, file,
                          "cell (col " + std::to_string(at.col0 + c) + ", row " + std::to_string(at.row0 + r) +
                              ") holds " + number_text(row[c]) + ", outside the plausible elevations [" +
                              number_text(o.valid_min) + ", " + number_text(o.valid_max) + "]" +
                              ": the file is corrupt (" + where + "), or its units need a wider valid range");
    }
  }
  return Status::Ok();
}

}  // namespace

Result<std::shared_ptr<const ElevationSource>> ElevationSource::open(const std::string& path,
                                                                     const SourceOptions& options) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT || errno == ENOTDIR) return source_error(ErrorCode::kNotFound, path, "no such file or folder");
    return source_error(ErrorCode::kIoError, path, std::string("cannot access: ") + std::strerror(errno));
  }
  if (options.block_cells == 0)
    return make_error(ErrorCode::kInvalidArgument, "block_cells: must be at least 1", "block_cells");
  if (!(options.valid_min < options.valid_max))  // NaN too
    return make_error(ErrorCode::kInvalidArgument, "valid range: the minimum must be below the maximum", "valid_range");

  std::shared_ptr<ElevationSource> source(new ElevationSource());
  source->options_ = options;
  source->id_ = BlockCache::next_source_id();
  ReadOptions read;
  read.band = options.band;
  read.max_block_bytes = options.max_block_bytes;

  if (!S_ISDIR(st.st_mode)) {
    read.allow_missing_crs = options.allow_missing_crs;
    auto raster = open_raster(path, read);
    if (!raster.ok()) return raster.error();
    SourceFile f;
    f.path = path;
    f.cells = Window{0, 0, (*raster)->header().width, (*raster)->header().height};
    f.raster = std::move(*raster);
    source->header_ = f.raster->header();
    source->files_.push_back(std::move(f));
  } else {
    std::vector<std::filesystem::path> names;
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(path, ec))
      if (is_raster_name(entry.path()) && !entry.is_directory()) names.push_back(entry.path());
    if (ec) return source_error(ErrorCode::kIoError, path, "cannot list the folder: " + ec.message());
    if (names.empty()) return source_error(ErrorCode::kDataError, path, "the folder holds no .tif, .tiff or .hgt file");
    std::sort(names.begin(), names.end());
    for (const auto& name : names) {
      auto raster = open_raster(name.string(), read);
      if (!raster.ok()) return raster.error();
      SourceFile f;
      f.path = name.string();
      f.raster = std::move(*raster);
      source->files_.push_back(std::move(f));
    }
    // One CRS, one cell size, corners on one grid.
    const DemHeader& first = source->files_.front().raster->header();
    const GeoTransform& t0 = first.georef.transform;
    if (!first.georef.has_crs())
      return source_error(ErrorCode::kUnsupported, first.source, "a mosaic's files need a CRS; this one has none");
    // "EPSG:32633", or the name of a CRS without one, for messages.
    auto crs_label = [](const Georeference& g) {
      if (g.crs.empty()) return "EPSG:" + std::to_string(g.epsg);
      auto crs = geodesy::Crs::of(g);
      return crs.ok() ? "'" + crs->name() + "'" : std::string("an unreadable CRS");
    };
    double west = t0.origin_x, north = t0.origin_y;
    for (const SourceFile& f : source->files_) {
      const DemHeader& h = f.raster->header();
      const GeoTransform& t = h.georef.transform;
      if (!h.georef.same_crs(first.georef))
        return source_error(ErrorCode::kDataError, f.path,
                            "CRS " + crs_label(h.georef) + " differs from " + crs_label(first.georef) + " of '" +
                                first.source + "'; a mosaic's files must share one CRS");
      if (std::abs(t.pixel_width - t0.pixel_width) > 1e-9 * std::abs(t0.pixel_width) ||
          std::abs(t.pixel_height - t0.pixel_height) > 1e-9 * std::abs(t0.pixel_height))
        return source_error(
            ErrorCode::kDataError, f.path,
            "cell size differs from that of '" + first.source +
                "'; a mosaic's files must share one cell size (resample them first, e.g. gdalwarp -tr)");
      west = std::min(west, t.origin_x);
      north = t0.pixel_height < 0 ? std::max(north, t.origin_y) : std::min(north, t.origin_y);
    }
    int width = 0, height = 0;
    for (SourceFile& f : source->files_) {
      const DemHeader& h = f.raster->header();
      const auto col0 = whole((h.georef.transform.origin_x - west) / t0.pixel_width);
      const auto row0 = whole((h.georef.transform.origin_y - north) / t0.pixel_height);
      if (!col0 || !row0)
        return source_error(ErrorCode::kDataError, f.path,
                            "its corner is not a whole number of cells from the other files' (a mosaic's files "
                            "must lie on one grid)");
      const long long col1 = *col0 + h.width, row1 = *row0 + h.height;
      if (col1 > std::numeric_limits<int>::max() / 2 || row1 > std::numeric_limits<int>::max() / 2)
        return source_error(ErrorCode::kResourceExhausted, path, "the mosaic is too large");
      f.cells =
          Window{static_cast<int>(*col0), static_cast<int>(*row0), static_cast<int>(col1), static_cast<int>(row1)};
      width = std::max(width, f.cells.col1);
      height = std::max(height, f.cells.row1);
    }
    DemHeader& h = source->header_;
    h.width = width;
    h.height = height;
    h.georef = first.georef;
    h.georef.transform = GeoTransform{west, t0.pixel_width, north, t0.pixel_height};
    h.nodata = first.nodata;
    h.format = "mosaic of " + std::to_string(source->files_.size()) + " files, " + first.format;
    h.tiled = true;
    source->mosaic_ = true;
  }

  std::uint64_t next = 0;
  for (SourceFile& f : source->files_) {
    lay_out_blocks(f, options.block_cells);
    f.first_block = next;
    next += static_cast<std::uint64_t>(f.blocks_x) * static_cast<std::uint64_t>(f.blocks_y);
  }
  source->block_count_ = next;
  source->header_.source = path;
  source->header_.blocks_total = next;
  if (!source->mosaic_) {
    source->header_.block_width = source->files_.front().block_width;
    source->header_.block_height = source->files_.front().block_height;
  }
  return std::shared_ptr<const ElevationSource>(std::move(source));
}

const SourceFile& ElevationSource::file_of(std::uint64_t block) const {
  assert(block < block_count_);
  auto it = std::upper_bound(files_.begin(), files_.end(), block,
                             [](std::uint64_t b, const SourceFile& f) { return b < f.first_block; });
  return *std::prev(it);
}

Window ElevationSource::block_cells(std::uint64_t block) const {
  const SourceFile& f = file_of(block);
  const std::uint64_t local = block - f.first_block;
  const int bx = static_cast<int>(local % static_cast<std::uint64_t>(f.blocks_x));
  const int by = static_cast<int>(local / static_cast<std::uint64_t>(f.blocks_x));
  const Window in_file{bx * f.block_width, by * f.block_height, std::min((bx + 1) * f.block_width, f.cells.width()),
                       std::min((by + 1) * f.block_height, f.cells.height())};
  return shifted(in_file, f.cells.col0, f.cells.row0);
}

std::vector<std::uint64_t> ElevationSource::blocks_in(const Window& window) const {
  std::vector<std::uint64_t> out;
  for (const SourceFile& f : files_) {
    const Window w = window.intersect(f.cells);
    if (w.empty()) continue;
    const Window local = shifted(w, -f.cells.col0, -f.cells.row0);
    for (int by = local.row0 / f.block_height; by <= (local.row1 - 1) / f.block_height; ++by)
      for (int bx = local.col0 / f.block_width; bx <= (local.col1 - 1) / f.block_width; ++bx)
        out.push_back(f.first_block + static_cast<std::uint64_t>(by) * static_cast<std::uint64_t>(f.blocks_x) +
                      static_cast<std::uint64_t>(bx));
  }
  return out;
}

// Cuts the window at every file edge inside it; each piece lies wholly in or
// out of every file, so testing one corner per piece finds every gap.
Status ElevationSource::check_covered(const Window& window) const {
  std::vector<Window> parts;
  std::vector<int> xs{window.col0, window.col1}, ys{window.row0, window.row1};
  for (const SourceFile& f : files_) {
    const Window w = window.intersect(f.cells);
    if (w.empty()) continue;
    parts.push_back(w);
    xs.insert(xs.end(), {w.col0, w.col1});
    ys.insert(ys.end(), {w.row0, w.row1});
  }
  std::sort(xs.begin(), xs.end());
  xs.erase(std::unique(xs.begin(), xs.end()), xs.end());
  std::sort(ys.begin(), ys.end());
  ys.erase(std::unique(ys.begin(), ys.end()), ys.end());
  for (std::size_t j = 0; j + 1 < ys.size(); ++j)
    for (std::size_t i = 0; i + 1 < xs.size(); ++i) {
      const bool covered =
          std::any_of(parts.begin(), parts.end(), [&](const Window& w) { return w.contains(xs[i], ys[j]); });
      if (covered) continue;
      const Window gap{xs[i], ys[j], xs[i + 1], ys[j + 1]};
      const GeoTransform& t = header_.georef.transform;
      const double x = t.x_at(0.5 * (gap.col0 + gap.col1 - 1)), y = t.y_at(0.5 * (gap.row0 + gap.row1 - 1));
      return source_error(ErrorCode::kNotFound, header_.source,
                          "no file covers " + describe_cells(gap) + " (around x " + std::to_string(x) + ", y " +
                              std::to_string(y) + "): a missing tile; add it, or read missing tiles as nodata");
    }
  return Status::Ok();
}

Result<Grid<float>> ElevationSource::load_block(std::uint64_t block) const {
  const SourceFile& f = file_of(block);
  const Window cells = block_cells(block);
  ReadStats read;
  auto got = f.raster->read_cells(shifted(cells, -f.cells.col0, -f.cells.row0), 1, &read);
  if (!got.ok()) {
    std::error_code ec;
    if (options_.missing_as_nodata && !std::filesystem::exists(f.path, ec))
      return Grid<float>(cells.width(), cells.height(), std::numeric_limits<float>::quiet_NaN());
    Error e = got.error();
    e.message += " (block " + std::to_string(block) + ": " + describe_cells(cells) + " of '" + header_.source + "')";
    return e;
  }
  HORIZON_RETURN_IF_ERROR(check_plausible(*got, read, cells, options_, f.path,
                                          "block " + std::to_string(block) + ": " + describe_cells(cells)));
  return got;
}

Result<Dem> ElevationSource::read(const Window& requested, BlockCache* cache, const RunControl* control,
                                  SourceReadStats* stats, unsigned threads, Grid<float>* reuse) const {
  const auto start = std::chrono::steady_clock::now();
  auto clipped = clip_read_window(requested, header_.width, header_.height, header_.source);
  if (!clipped.ok()) return clipped.error();
  const Window window = *clipped;
  const Status covered = check_covered(window);
  if (!covered.ok() && !options_.missing_as_nodata) return covered.error();

  SourceReadStats local;
  local.window = window;
  local.blocks_total = block_count_;
  const std::vector<std::uint64_t> blocks = blocks_in(window);
  local.blocks = blocks.size();
  for (const SourceFile& f : files_) local.files += !window.intersect(f.cells).empty();

  Dem dem;
  dem.georef = header_.georef;
  dem.georef.transform = header_.georef.transform.shifted(window.col0, window.row0);
  dem.nodata = header_.nodata;
  dem.source = header_.source;
  dem.format = header_.format;
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  // Where files overlap the first in name order wins: later files are copied first.
  auto copy_into = [&window](Grid<float>& out, const Grid<float>& cells, const Window& at) {
    const Window w = window.intersect(at);
    for (int r = w.row0; r < w.row1; ++r)
      std::copy_n(cells.row(r - at.row0) + (w.col0 - at.col0), w.width(),
                  out.row(r - window.row0) + (w.col0 - window.col0));
  };

  if (!cache) {
    std::vector<const SourceFile*> under;
    for (const SourceFile& f : files_)
      if (!window.intersect(f.cells).empty()) under.push_back(&f);
    if (under.size() == 1 && covered.ok()) {  // one file holds the whole window: read it in place
      const SourceFile& f = *under.front();
      auto cells = f.raster->read_cells(shifted(window, -f.cells.col0, -f.cells.row0), threads, &local.file);
      if (!cells.ok()) return cells.error();
      HORIZON_RETURN_IF_ERROR(
          check_plausible(*cells, local.file, window, options_, f.path, describe_cells(window), threads));
      dem.elevation = std::move(*cells);
      local.cells_decoded = local.file.cells_decoded;
    } else {
      dem.elevation = Grid<float>(window.width(), window.height(), kNaN);
      for (auto it = under.rbegin(); it != under.rend(); ++it) {
        HORIZON_RETURN_IF_ERROR(check_control(control));
        const SourceFile& f = **it;
        const Window part = window.intersect(f.cells);
        ReadStats read;
        auto cells = f.raster->read_cells(shifted(part, -f.cells.col0, -f.cells.row0), threads, &read);
        if (!cells.ok()) {
          std::error_code ec;
          if (options_.missing_as_nodata && !std::filesystem::exists(f.path, ec)) continue;
          return cells.error();
        }
        HORIZON_RETURN_IF_ERROR(check_plausible(*cells, read, part, options_, f.path, describe_cells(part), threads));
        copy_into(dem.elevation, *cells, part);
        local.cells_decoded += read.cells_decoded;
      }
    }
  } else {
    std::vector<BlockCache::Want> wants;
    wants.reserve(blocks.size());
    std::shared_ptr<const ElevationSource> self = shared_from_this();  // a decode may outlive this call
    for (std::uint64_t b : blocks) wants.push_back({{id_, b}, [self, b] { return self->load_block(b); }});
    auto got = cache->fetch(wants, control, &local.cache);
    if (!got.ok()) return got.error();
    local.cells_decoded = local.cache.bytes_decoded / sizeof(float);
    if (reuse && reuse->capacity() >= window.cell_count()) {
      dem.elevation = std::move(*reuse);
      dem.elevation.reshape(window.width(), window.height());
      if (!covered.ok()) std::fill(dem.elevation.values().begin(), dem.elevation.values().end(), kNaN);
    } else {
      dem.elevation = covered.ok() ? Grid<float>(window.width(), window.height(), kUninitialized)
                                   : Grid<float>(window.width(), window.height(), kNaN);
    }
    for (std::size_t i = got->size(); i-- > 0;) copy_into(dem.elevation, *(*got)[i], block_cells(blocks[i]));
  }
  local.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (stats) *stats = local;
  return dem;
}

Result<ElevationStats> ElevationSource::scan(unsigned threads, BlockCache* cache, const RunControl* control) const {
  std::mutex mutex;
  ElevationStats total;
  std::optional<Error> failure;
  bool any = false;
  std::shared_ptr<const ElevationSource> self = shared_from_this();
  const Status status = parallel_for(block_count_, threads, control, [&](std::size_t b) {
    Result<Block> block = Error{};
    if (cache) {
      const BlockCache::Want want{{id_, b}, [self, b] { return self->load_block(b); }};
      auto got = cache->fetch(std::span(&want, 1));
      block = got.ok() ? Result<Block>(got->front()) : Result<Block>(got.error());
    } else {
      auto cells = load_block(b);
      block = cells.ok() ? Result<Block>(std::make_shared<const Grid<float>>(std::move(*cells)))
                         : Result<Block>(cells.error());
    }
    if (!block.ok()) {
      std::lock_guard lock(mutex);
      if (!failure) failure = block.error();
      return;
    }
    const ElevationStats s = elevation_stats(**block);
    std::lock_guard lock(mutex);
    if (s.valid_cells) {
      total.min = any ? std::min(total.min, s.min) : s.min;
      total.max = any ? std::max(total.max, s.max) : s.max;
      any = true;
    }
    total.valid_cells += s.valid_cells;
    total.nodata_cells += s.nodata_cells;
  });
  if (failure) return *failure;
  if (!status.ok()) return status.error();
  return total;
}

}  // namespace horizon::terrain
