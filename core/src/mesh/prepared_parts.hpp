// mesh/prepared_parts.hpp (private) — the parts of a PreparedMesh that
// are derived from others, rebuilt alike by prepare_mesh and by a cache
// load.
#pragma once

#include "horizon/mesh/prepared_mesh.hpp"

namespace horizon::mesh {

// chain_begin, corner_t, corner_z, chain_slope from regions.
void flatten_regions(PreparedMesh& mesh);

// centre_directions and sector_starts from sectors.
void set_sector_tables(PreparedMesh& mesh);

// columns from groups, top_level, sectors and the region and wall tables.
void set_group_columns(PreparedMesh& mesh);

}  // namespace horizon::mesh
