// libFuzzer target: mesh files (OBJ, PLY text or binary) on arbitrary
// bytes. The first byte picks the extension (read_tin dispatches on it); the
// rest is the file. read_tin must answer an Error or a TIN that passed
// check_height_field, never crash, hang or read out of bounds; a TIN it
// accepts has every triangle counter-clockwise, and its horizons (8
// sectors) are computed when it is small; a smaller one is prepared whole
// and culled in both modes.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "horizon/mesh/cull.hpp"
#include "horizon/mesh/horizons.hpp"
#include "horizon/mesh/prepared_mesh.hpp"
#include "horizon/mesh/tin_io.hpp"
#include "scratch_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace horizon::mesh;
  if (size < 1) return 0;
  static const char* const kNames[] = {"mesh.obj", "mesh.ply"};
  const auto written = horizon::fuzz::write_scratch("mesh", kNames[data[0] % 2], data + 1, size - 1);
  if (!written) return 0;
  const std::filesystem::path& path = *written;
  auto tin = read_tin(path.string());
  if (!tin.ok()) return 0;
  for (const TinTriangle& t : tin->triangles)
    if (signed_area(*tin, t) < 0.0) std::abort();  // checked, so never clockwise
  if (tin->vertices.size() <= 2000) (void)compute_horizons(tin->vertices, {8, 1, 1});
  // Small TINs are prepared whole and culled in both modes; every group's
  // run must lie inside the triangles.
  if (tin->vertices.size() <= 300) {
    PrepareOptions options;
    options.horizons = {8, 2, 1};
    options.crystals.seeds = 4;
    options.crystals.min_group_size = 2;
    auto prepared = prepare_mesh(*tin, options);
    if (!prepared.ok()) std::abort();  // a checked TIN and valid options always prepare
    for (const MeshGroup& g : prepared->groups)
      if (g.first_triangle + g.triangle_count > prepared->tin.triangles.size()) std::abort();
    const TinVertex& v = tin->vertices[0];
    for (CullMode mode : {CullMode::kApproximate, CullMode::kConservative})
      if (!cull(*prepared, {{v.x + 1, v.y + 1, v.z + 2}, {}, {}, mode}).ok()) std::abort();
  }
  return 0;
}
