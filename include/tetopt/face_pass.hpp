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
// Vertex moves.  A vertex v moves the centroids of the tets around it, and
// so the non-orthogonality of every face of those tets (their faces with
// tets outside the star included), and the normals of the faces through v.
// A sweep takes the interior faces near the mesh's largest value (within
// kBand degrees of it, at least the kTop worst), and for each free vertex of
// their two tets, in ascending id order, minimises the largest
// non-orthogonality over the faces of v's star tets by a compass search
// (Kolda, Lewis & Torczon 2003: the six axis directions, step halved on
// failure, from a tenth of the star's mean edge length).  A position is
// committed when that local largest value falls, every star tet stays
// positive (exact orient3d) and, with a guard, every star tet passes it (no
// per-tet measure worse than the mesh's current worst, alpha's included).
//
// Topology.  Once a sweep of moves no longer lowers the largest value by
// kGain, each further sweep first works on the same faces with the
// topological operations of TopoEditor (topo.hpp): on the face's two tets,
// the 2-3 flip and the multi-face removal across each face (Shewchuk 2002)
// and the removal of each edge (3-2, 4-4, n -> 2n-4), whether or not they
// remove the face itself (an operation beside it gives it a new apex).  The
// editor plans each (exact orientation, constrained faces and listed edges
// untouched, new tets chosen by their worst alpha) without demanding better
// alpha (TopoEditor::remove_edge_judged / remove_face_judged); the pass
// takes the option whose new tets' faces (those shared with the unchanged
// tets around the cavity included) have the lowest largest value, if that
// is below the largest over the faces of the tets it replaces and every new
// tet passes the guard (alpha_floor without one).  When the only refused new
// tets share a free vertex, the option is taken together with a move of that
// vertex found by a compass search after the operation (first raising the
// refused tets' worst alpha until the guard admits them, then lowering the
// faces' largest value): the faces compared then also include those of the
// vertex's other tets.  Then the vertex moves run again.  (Topology from
// the first sweep was tried: on jittered boxes its early changes left the
// moves worse places to go.)
//
// Every committed change lowers the largest value over exactly the faces
// whose value it changes, so the mesh's largest non-orthogonality never
// rises, and no tet is created or moved below the guard.  Sweeps of each
// kind stop after `sweeps` or when the largest falls by at most kGain
// (0.01 degree).  Deterministic: serial, in a fixed order.
//
// What vertex moves cannot do: a face with two constrained vertices whose
// two tets' other vertices are constrained too has d = C_nei - C_own fixed
// (d is a quarter of the difference of the two apexes), so only the face's
// normal turns, about its constrained edge e: its non-orthogonality is at
// least asin(|d.e| / (|d||e|)) wherever the free vertex goes.  tire's worst
// face (74.73 degrees) is such a face, and the topology does not take it
// either under the guards.  Its constrained edge (c1, c2) is a boundary
// edge whose shell is two tets, (c1, c2, v, x) and (c1, c2, v, y), between
// the boundary faces (c1, c2, x) and (c1, c2, y), which stay.  The tets
// around (c1, c2) must lead from x to y: through one vertex w between them
// (v or another), the face (c1, c2, w) has the apexes x and y again and the
// same floor; through none, the tet (c1, c2, x, y), four constrained
// vertices, mean ratio 0.21 below the mesh's worst 0.31, which the guard
// refuses (every valid option tried that lowers the face holds it; with --no-guard,
// where only alpha's worst is kept and it passes, the pass takes tire to
// 57.6 degrees); through two or more, several operations at once, which the
// pass does not search.  checkMesh's face skewness is neither optimised nor
// guarded here (reported before and after).
#pragma once
#include <cstdint>

#include "tetopt/guard.hpp"
#include "tetopt/mesh.hpp"

namespace tetopt {

struct FacePassOptions {
  int sweeps = 20;        ///< at most this many sweeps of moves, and as many of topology and moves
  Guard* guard = nullptr; ///< every committed star passes it (not owned)
  /// Without a guard: star tets may not fall below this alpha (the mesh's
  /// worst alpha when the pass starts, so that the pass never costs alpha).
  double alpha_floor = 0;
  /// Also change the topology near the worst faces (2-3 flips, multi-face
  /// and edge removals, once the moves alone stall); false: vertex moves only.
  bool topology = true;
};

struct FacePassStats {
  double worst_before = 0, worst_after = 0;  ///< largest interior non-orthogonality (degrees)
  int64_t moves = 0;                          ///< committed vertex positions
  int64_t face_removals = 0;                  ///< committed 2-3 flips and multi-face removals
  int64_t edge_removals = 0;                  ///< committed edge removals (3-2, 4-4, n -> 2n-4)
  int64_t combined = 0;  ///< removals taken with a move of a free vertex of their new tets (also counted above)
  /// Why the largest face stays, at the end: worst_move_floor >= 0 when
  /// both its apexes and at least two of its vertices are constrained, so
  /// that no vertex move takes it below that value (degrees; see above);
  /// -1 otherwise.  With topology: of the operations of the topological
  /// step on its two tets, how many would lower the largest value over the
  /// faces they change (worst_lowering_options) and how many of those hold
  /// a refused new tet (guard, or alpha_floor) with four constrained
  /// vertices, which no move can rescue (worst_constrained_refused).
  double worst_move_floor = -1;
  int worst_lowering_options = 0, worst_constrained_refused = 0;
  int64_t vertices_tried = 0;
  int sweeps = 0;
  double seconds = 0;
};

/// Requires m's topology (adjacency and vertex stars); keeps it valid:
/// coordinates of free vertices change and, with `topology`, tets are
/// replaced (ids change; face_mask, tet_kind and the vertex stars are
/// rebuilt as TopoEditor::finish leaves them).
FacePassStats face_pass(TetMesh& m, const FacePassOptions& o = {});

/// The largest interior-face non-orthogonality of m, in degrees (0 when m has
/// no interior face).  Requires m.adj.
double max_non_orthogonality(const TetMesh& m);

}  // namespace tetopt
