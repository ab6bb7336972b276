// tetopt/face_pass.hpp — lowering OpenFOAM's largest face non-orthogonality
// (issue 26, `--objective openfoam`).
//
// checkMesh's non-orthogonality of an interior face is the angle between
// the face's area vector and the line joining the centroids of its two tets
// (measures.hpp, face_non_orthogonality); OpenFOAM's solvers need
// non-orthogonal correctors above 70 degrees and checkMesh fails a mesh
// whose largest reaches 90.  It is a measure of a face between two tets,
// not of one tet, so the per-tet stages of improve() cannot optimise it;
// this pass runs after them.
//
// A vertex v moves the centroids of the tets around it, and so the
// non-orthogonality of every face of those tets (their faces with tets
// outside the star included), and the normals of the faces through v.  The
// pass repeatedly takes the interior faces near the mesh's largest value
// (within kBand degrees of it, at least the kTop worst), and for each free
// vertex of their two tets, in ascending id order, minimises the largest
// non-orthogonality over the faces of v's star tets by a compass search
// (Kolda, Lewis & Torczon 2003: the six axis directions, step halved on
// failure, from a tenth of the star's mean edge length).  A position is
// committed when that local largest value falls, every star tet stays
// positive (exact orient3d) and, with a guard, every star tet passes it (no
// per-tet measure worse than the mesh's current worst, alpha's included).
// Only faces of the star change, so the mesh's largest non-orthogonality
// never rises.  Sweeps continue while the largest falls by more than 0.01
// degree.  Deterministic: serial, in a fixed order.
//
// What vertex moves cannot do: a face with two constrained vertices whose
// two tets' other vertices are constrained too has d = C_nei - C_own fixed
// (d is a quarter of the difference of the two apexes), so only the face's
// normal turns, about its constrained edge e: its non-orthogonality is at
// least asin(|d.e| / (|d||e|)) wherever the free vertex goes.  tire's worst
// face (74.73 degrees) and flange's (69.45) are such faces, already at that
// minimum.  A 2-3 flip would remove them but is not valid there (the segment
// between the two apexes misses the face); removing one of the face's edges
// could, and is not done.  checkMesh's face skewness is neither optimised
// nor guarded here (reported before and after).
#pragma once
#include <cstdint>

#include "tetopt/guard.hpp"
#include "tetopt/mesh.hpp"

namespace tetopt {

struct FacePassOptions {
  int sweeps = 20;        ///< at most this many sweeps
  Guard* guard = nullptr; ///< every committed star passes it (not owned)
  /// Without a guard: star tets may not fall below this alpha (the mesh's
  /// worst alpha when the pass starts, so that the pass never costs alpha).
  double alpha_floor = 0;
  /// Also remove faces by 2-3 flips, multi-face and edge removal (each
  /// sweep, before the vertex moves); false: vertex moves only.
  bool topology = true;
};

struct FacePassStats {
  double worst_before = 0, worst_after = 0;  ///< largest interior non-orthogonality (degrees)
  int64_t moves = 0;                          ///< committed vertex positions
  int64_t face_removals = 0;                  ///< committed 2-3 flips and multi-face removals
  int64_t edge_removals = 0;                  ///< committed edge removals (3-2, 4-4, n -> 2n-4)
  int64_t combined = 0;  ///< removals taken with a move of a free vertex of their new tets (also counted above)
  int64_t vertices_tried = 0;
  int sweeps = 0;
  double seconds = 0;
};

/// Requires m's topology (adjacency and vertex stars); keeps it valid (only
/// coordinates of free vertices change).
FacePassStats face_pass(TetMesh& m, const FacePassOptions& o = {});

/// The largest interior-face non-orthogonality of m, in degrees (0 when m has
/// no interior face).  Requires m.adj.
double max_non_orthogonality(const TetMesh& m);

}  // namespace tetopt
