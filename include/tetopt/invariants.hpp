// tetopt/invariants.hpp — the promise, checked.
//
// Before improving, capture_invariants() records what must not change: the
// coordinates of every constrained vertex (bit for bit), the set of
// constrained faces (boundary, region interfaces, listed triangles) as sorted
// vertex triples with the refs on either side, and the volume of every region.
// After improving, check_invariants() proves the result keeps the promise:
// same vertices at the same bits, the same constrained faces, every listed
// edge that was an edge of the mesh still one, no tet made
// inverted or flat (exact orient3d, see below), region volumes equal to 1e-9
// of the total volume.  Any failure is a bug: the caller must not write the
// mesh.
//
// Inverted or flat input tets.  A mesh may arrive tangled; tetopt repairs
// what it can (untangle.hpp) but must never make it worse.  Let N0 be the
// number of non-positive (inverted or flat) tets in the snapshot and S the
// set of vertices of those tets.  The check passes when, afterwards,
//   (1) the number of non-positive tets is <= N0, and
//   (2) every non-positive tet has all four vertices in S.
// So a positive input mesh must stay entirely positive (N0 = 0, S empty), a
// tangled one may only keep (a subset of) its tangles, and no region of
// positive input tets can become inverted.
// Cost: O(nt log nt) time, about 12 bytes per constrained face of memory.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "tetopt/mesh.hpp"
#include "tetopt/status.hpp"

namespace tetopt {

struct InvariantSnapshot {
  int32_t nv = 0;
  std::vector<int32_t> vertices;              ///< constrained vertex ids, ascending
  std::vector<double> coords;                 ///< their coordinates (3 each)
  std::vector<std::array<int32_t, 5>> faces;  ///< sorted (a,b,c, ref inside, ref outside or -1)
  std::vector<std::pair<int32_t, double>> region_volume;
  std::vector<int32_t> tris, tri_ref;         ///< listed triangles as read
  std::vector<int32_t> edges, edge_ref;       ///< listed edges as read
  std::vector<int32_t> edges_in_mesh;         ///< ids of the listed edges that are edges of a tet
  int64_t nonpositive = 0;                    ///< inverted or flat tets (exact), N0 above
  std::vector<int32_t> tangled_vertices;      ///< S above: vertices of those tets, ascending
};

/// Ids of the tets that are not Positive under the exact orient3d (ascending).
/// threads: worker threads for the scans (0 = all cores); every result
/// below is the same for every count.
std::vector<int32_t> nonpositive_tets(const TetMesh& m, int threads = 1);

/// Requires m's topology (build_topology).
InvariantSnapshot capture_invariants(const TetMesh& m, int threads = 1);

/// Requires m's topology to be current.  Returns Invariant with a message
/// naming the broken promise ("constrained vertex 17 moved", ...).
Status check_invariants(const TetMesh& m, const InvariantSnapshot& before, int threads = 1);

}  // namespace tetopt
