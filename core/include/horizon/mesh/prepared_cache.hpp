// horizon/mesh/prepared_cache.hpp — prepared meshes kept on disk.
//
// Preparing a 100 000-vertex TIN takes seconds; a daemon restarting or a
// CLI run repeating should not pay them again. A cache directory holds one
// file per (mesh, knobs): its name is a hash of both
// ("<16 hex digits>.hzmesh"), and the file itself holds the mesh and the
// knobs it was prepared from in full, which a load compares exactly, so a
// hash collision can only cost a recomputation, never a wrong answer. The
// thread count is not a knob (it does not change the result).
//
// Files are written whole or not at all (a temporary file renamed into
// place) and end with a 64-bit FNV-1a checksum of the rest. A load checks
// the checksum, bounds every count by the bytes left, and checks every
// index the cull follows; a truncated or damaged file is kDataError naming
// it, and prepare_cached then prepares afresh and replaces it.
#pragma once

#include <optional>
#include <string>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/mesh/prepared_mesh.hpp"

namespace horizon::mesh {

// The file name (without directory) for `tin` prepared with `options`.
std::string prepared_cache_name(const Tin& tin, const PrepareOptions& options);

// Writes `prepared` (made from `input` with `options`) to `path`.
Status save_prepared(const std::string& path, const Tin& input, const PrepareOptions& options,
                     const PreparedMesh& prepared);

// The mesh prepared from `input` with `options`, if `path` holds it;
// nullopt when there is no such file or it holds another mesh or other
// knobs; kDataError when it is not a readable cache file.
Result<std::optional<PreparedMesh>> load_prepared(const std::string& path, const Tin& input,
                                                  const PrepareOptions& options);

struct CacheUse {
  bool hit = false;         // loaded, not prepared
  std::string path;         // the cache file
  std::string note;         // why a file present was not used (corrupt), else empty
};

// prepare_mesh through the cache in `directory` (created if missing).
// A cache that cannot be written is not an error: `use->note` says why.
Result<PreparedMesh> prepare_cached(const Tin& tin, const PrepareOptions& options, const std::string& directory,
                                    CacheUse* use = nullptr, const RunControl* control = nullptr);

}  // namespace horizon::mesh
