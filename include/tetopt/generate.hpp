// tetopt/generate.hpp — meshes the project makes itself, for tests, fuzzing
// and benchmarks (no fetched files needed).
#pragma once
#include <cstdint>

#include "tetopt/mesh.hpp"

namespace tetopt {

struct BoxMeshOptions {
  int nx = 4, ny = 4, nz = 4;   ///< cells per axis; 6 tets per cell (Kuhn split)
  double jitter = 0.0;          ///< interior-vertex displacement, fraction of the cell size (0..0.45)
  uint64_t seed = 1;            ///< for the jitter
  int regions = 1;              ///< 2: cells with x-index < nx/2 get ref 1, others ref 2
};

/// Axis-aligned box [0,nx]x[0,ny]x[0,nz] split into cubes and each cube into
/// six positive tets around its main diagonal (Kuhn / Freudenthal split, which
/// is conforming across cubes).  Jitter moves only vertices strictly inside the
/// box (and off the region interface), and any move that would invert a tet is
/// undone, so the result is always valid.  Boundary triangles are listed with
/// ref 1.  Topology is not built.  Throws std::invalid_argument when a
/// count is below 1 or the mesh would have more than 2^31 - 1 tets (ids
/// are 32-bit).
TetMesh make_box_mesh(const BoxMeshOptions& opt);

}  // namespace tetopt
