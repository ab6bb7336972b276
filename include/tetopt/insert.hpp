// tetopt/insert.hpp — vertex insertion, behind an explicit flag.
//
// Flips cannot remove a sliver whose four vertices are all constrained while
// none of its faces is (an "interior" all-boundary tet across a thin part),
// and smoothing has no free vertex to move.  Klingner & Shewchuk 2007
// ("Aggressive tetrahedral mesh improvement", IMR) add a vertex: here the
// cavity is the poor tet plus its neighbours across unconstrained faces of
// the same region, the new vertex is placed by a compass search maximising
// the worst alpha of the fan it forms with the cavity's outer faces, and the
// fan replaces the cavity only if every new tet is exactly positive
// (orient3d) and the cavity's worst alpha rises by more than the margin
// (TopoEditor::insert_vertex).  Constrained faces are never removed (they
// stay outer faces of the cavity), constrained vertices never move, new
// vertices are free, get vert_ref 0 (point fields 0) and are appended at the
// end so every existing vertex id, and so every listed triangle and edge,
// keeps its meaning.  Volume per region is conserved (same cavity, same ref).
//
// Cavities tried: t plus every subset of its joinable face neighbours, then
// t plus all of them grown one tet at a time across the unconstrained outer
// face whose fan tet is worst (<= 12 steps, stop after 3 without gain, <= 32
// tets / 32 outer faces); every vertex of the cavity must stay on its boundary.
// Cost: per visited tet <= ~28 compass searches of <= 400 early-exit fan
// evaluations; a pass is O(nt) to scan plus the visited tets, then one
// TopoEditor::finish().  Impeller (438k tets) with --allow-insert: 73 s.
#pragma once
#include <cstdint>
#include <vector>

#include "tetopt/guard.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/objective.hpp"
#include "tetopt/status.hpp"

namespace tetopt {

struct InsertOptions {
  double quality_threshold = 0.3;  ///< visit tets with alpha below this
  int passes = 2;                  ///< stop after this many passes or a pass with no insertion
  double margin = 1e-6;            ///< the cavity's worst alpha must rise by more than this
  bool all_boundary_only = false;  ///< visit only kind-4 tets (all vertices constrained)
  /// Visit only tets with at least this many constrained vertices: smoothing
  /// fixes tets with two or more free vertices far more cheaply, and visiting
  /// every poor tet of a 400k-tet mesh costs minutes (impeller: 274 s with 0).
  int min_kind = 3;
  /// Also remove vertices (TopoEditor::remove_vertex, edge contraction of a
  /// free vertex of the tet) where insertion does not apply; removed
  /// vertices stay in the array, unreferenced, listed in InsertStats.
  bool remove = false;
  bool insert = true;  ///< false: removal only
  Objective objective = Objective::Alpha;  ///< the q that stands for alpha above (objective.hpp)
  const Guard* guard = nullptr;            ///< guards (guard.hpp); nullptr: none
};

struct InsertStats {
  int64_t inserted = 0, tried = 0;
  int64_t removed = 0;                    ///< vertices removed (InsertOptions::remove)
  std::vector<int32_t> removed_vertices;  ///< their ids (unreferenced now; compact_vertices drops them)
  double alpha_worst_before = 0, alpha_worst_after = 0;
  int64_t vertices_before = 0, vertices_after = 0;
  int64_t tets_before = 0, tets_after = 0;
  double seconds = 0;
  Status status;  ///< not ok when the topology could not be built
};

/// Inserts free vertices into cavities of poor tets (see the essay).  Builds
/// the topology if missing and leaves it current.  Deterministic (index
/// order).  The mesh's worst alpha never decreases.
InsertStats insert_pass(TetMesh& m, const InsertOptions& o = {}, const LogFn& log = {});

}  // namespace tetopt
