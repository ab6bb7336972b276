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
// Cavities tried: t alone, then t plus all its joinable face neighbours
// grown one tet at a time across the unconstrained outer face whose fan tet
// is worst (<= 12 steps, stop after 3 without gain, <= 32 tets / 32 outer
// faces); every vertex of the cavity must stay on its boundary.  Each gets
// a coarse compass search, the best one a fine one unless the coarse one
// stayed below 0.9 of what acceptance needs.  Cost: per tried tet
// <= 14 compass searches of <= 400 early-exit fan evaluations; a pass is
// O(nt) to scan plus the tried tets, then one TopoEditor::finish().  A tet
// refused before is not tried again while its signature is unchanged
// (InsertMemo; the remesher's rounds share one): on raw tetgen output of
// tests/data/gmsh/thin_wall.geo (tw_A) most of the ~3,000 tets of each pass
// are skipped so, and the whole run took 0.75x the time (docs/benchmarks.md,
// twenty-second session).
#pragma once
#include <atomic>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "tetopt/guard.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/objective.hpp"
#include "tetopt/status.hpp"

namespace tetopt {

/// What insert_pass remembers between calls (InsertOptions::memo): for each
/// tet it tried and could neither insert into nor remove a vertex at, a
/// signature of what the attempt started from (the tet and its face
/// neighbours: their vertices and those vertices' coordinates, the
/// vertices across their faces, their refs and constrained faces; with
/// removal on, the same of the stars of its free vertices; the options
/// that change an attempt; no tet index, so that it survives the
/// compaction of tet slots).  A tet whose signature is unchanged is not
/// tried again.  Owned by the caller, valid for one mesh.
struct InsertMemo {
  std::unordered_map<uint64_t, uint64_t> refused;  ///< hash of the sorted vertex ids -> signature
};

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
  /// Refusals remembered across calls (see InsertMemo); nullptr: only
  /// across the passes of this call.  A refusal stands while what the
  /// signature covers is unchanged, provided the guards have not loosened
  /// since (the caller's part: improve's rounds only tighten them, and
  /// start a new memo with each trial), except where a cavity grown past
  /// the face neighbours changed only there (see insert_pass).
  InsertMemo* memo = nullptr;
  /// Threads for the position searches made ahead (TopoEditor::plan_inserts;
  /// 0: every hardware thread); the outcome is the same for every count.
  int threads = 1;
};

struct InsertStats {
  int64_t inserted = 0, tried = 0;
  int64_t skipped = 0;                    ///< not tried: refused in an earlier call, signature unchanged (InsertMemo)
  int64_t removed = 0;                    ///< vertices removed (InsertOptions::remove)
  /// Position searches made ahead in parallel (InsertOptions::threads > 1):
  /// used, and made again because a commit had changed what they read.
  int64_t planned_used = 0, planned_redone = 0;
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

/// The tets at the mesh's worst alpha (within o.margin) whose four vertices
/// are all constrained, where no smoothing can reach: each that has an edge
/// on no constrained face whose split (TopoEditor::split_edge at its
/// midpoint, else at 0.3 or 0.7 of it) lifts the new tets above the tet's
/// alpha gets that split, the first such in that order and local edge
/// order, leaving a free vertex there.  Uses
/// o.margin, o.objective and o.guard; returns the number split.
///
/// With 0 < forced < 1 a split need not lift the tet: the first whose new
/// tets all keep at least forced times the tet's alpha is taken, with no
/// guard, for a caller that runs the rounds after it and keeps their result
/// only where it ends higher on alpha and no worse on every guarded measure
/// (improve(): the tet's new free vertex needs the smoothing of its
/// neighbours, and their flips, before the shell can rise).
int64_t split_locked_worst(TetMesh& m, const InsertOptions& o = {}, double forced = 0);

/// The interior remesher's refinement and coarsening (issue 27), the logic
/// of MMG's -optim on a size field (Dapogny, Dobrzynski & Frey 2014, "Three-
/// dimensional adaptive domain remeshing, implicit domain meshing, and
/// applications to free and moving boundary problems", §4: split edges
/// longer than ~1.4 h, collapse those shorter than ~0.7 h; smoothing and
/// swaps in between).  Only edges on no constrained face are split, and only
/// free vertices are collapsed away, so the boundary, the interfaces and
/// every listed entity stay bit for bit.
///
/// Size field h per vertex, in this order: RemeshOptions::size (> 0: one
/// size everywhere); else a 1-component point field named "size" or "h"
/// (values > 0); else, for a vertex on a constrained triangle, the mean
/// length of the constrained triangles' edges at it (the surface's own
/// size), and for any other vertex the mean length of its edges.  A
/// constrained vertex whose tets have no free vertex (a raw constrained
/// Delaunay mesh, `tetgen -p`: nothing inside says how fine the volume
/// should be) takes the larger of its surface size and MMG -optim's size
/// (the mean length of all its edges, MMG3D_doSol) limited by a gradation:
/// over the input's edges it grows by at most 0.15 per unit length from any
/// vertex's (MMG's gradation, §4 of the paper, with a slope chosen on
/// body_in_box: docs/benchmarks.md, nineteenth session).  A vertex made by a
/// split gets the mean of its edge's two sizes.  An edge ab is
/// long when |ab| > split_above * (h_a + h_b) / 2 and short when
/// |ab| < collapse_below * (h_a + h_b) / 2.
///
/// A split or collapse is taken when its new tets are exactly positive, pass
/// the guards and their worst quality is at least max(floor, ratio *
/// min(old worst, cap)) (Acceptance, topo.hpp), with floor >= the mesh's
/// worst quality at the start: the worst tet never gets worse.
struct RemeshOptions {
  double size = 0;              ///< > 0: target edge length everywhere
  double split_above = 1.4;     ///< split edges longer than this times the size
  /// An edge joining two constrained vertices (across the volume: only a
  /// split or a flip removes it) is long above the smaller of this and
  /// split_above.
  double split_spanning = 1.4;
  double collapse_below = 0.6;  ///< collapse edges shorter than this times the size
  /// > 0: the slope of the raw mesh's graded size (above: h grows by at
  /// most this per unit length; MMG's -hgrad R is log R); 0: 0.15.
  double gradation = 0;
  int sweeps = 1;               ///< split + collapse sweeps in this call
  /// Per sweep, up to this many (collect long edges, split them) loops,
  /// ending when one splits at most 2% of what it found; then the same for
  /// collapses.
  int max_loops = 2;
  double cap = 0.3;             ///< Acceptance::cap
  double ratio = 0.9;           ///< Acceptance::ratio
  /// Vertices with an id below this are never collapsed away (the input's,
  /// without --allow-remove); constrained vertices never are.
  int32_t removable_from = 0;
  Objective objective = Objective::Alpha;
  const Guard* guard = nullptr;
  const std::atomic<bool>* stop = nullptr;
};

struct RemeshStats {
  int64_t splits = 0, collapses = 0;
  int64_t long_edges = 0;   ///< long edges found by the last sweep (before its splits)
  int64_t short_edges = 0;  ///< short edges found by the last sweep
  std::vector<int32_t> removed_vertices;
  double seconds = 0;
  Status status;
};

/// One or more split / collapse sweeps (see RemeshOptions).  `h` is the size
/// field: when its size is not m.nv() it is computed as described above; on
/// return it has an entry for every vertex, new ones included (removed
/// vertices keep theirs).  Builds the topology when missing and leaves it
/// current (removed vertices stay in the array, unreferenced).
RemeshStats remesh_pass(TetMesh& m, std::vector<double>& h, const RemeshOptions& o = {}, const LogFn& log = {});

/// The remesher's first step where the volume is far coarser than the size
/// field (issue 27 item 5; raw `tetgen -p` output has no interior vertex):
/// Delaunay refinement by size (Shewchuk 1998, "Tetrahedral mesh generation
/// by Delaunay refinement", SoCG: insert the circumcentre of a tet whose
/// circumradius is too large).  Tets whose circumradius exceeds
/// radius_above x the mean size at their four vertices are taken largest
/// ratio first; each one's circumcentre is inserted by
/// TopoEditor::insert_point (a Bowyer-Watson cavity within the tet's region,
/// never across a constrained face) when the walk to it stays inside the
/// region and the new tets' worst quality is admitted by the same
/// Acceptance as split_edge (floor: the mesh's worst at the start, so the
/// worst never falls).  A circumcentre beyond a constrained face is skipped:
/// the tet is left to the cavities of its neighbours' circumcentres and to
/// the split sweeps.  One insertion makes one vertex and about a cavity of
/// tets, where reaching the same density by edge splits inserted 4-5 times
/// the net vertices and collapsed most of them again (docs/benchmarks.md,
/// nineteenth session).  The new vertex's size is the mean of its tet's,
/// except on a raw mesh (no free vertex near a constrained one, as above):
/// there a constrained vertex keeps its surface size in `h`, the graded
/// size of remesh_pass becomes a cap, and a circumcentre at distance r from
/// its tet's vertices takes min(the tet's mean cap, the least size at its
/// vertices + log(1.3) r), MMG's default gradation, so the layer of tets on
/// the boundary triangles grows from the triangles' own size (on
/// cylinder_hole's raw mesh the mean alpha went from 0.679 to 0.735-0.741,
/// MMG -optim's is 0.686).
struct RefineOptions {
  double size = 0;            ///< > 0: target edge length everywhere (as RemeshOptions::size)
  double radius_above = 0.8;  ///< refine tets whose circumradius exceeds this times their size
  /// > 0: the slope of the raw mesh's graded size (as RemeshOptions::
  /// gradation), and of the new vertices' size from the wall where it is
  /// above log(1.3); 0: 0.15 and log(1.3).
  double gradation = 0;
  double cap = 0.3;           ///< Acceptance::cap
  double ratio = 0.9;         ///< Acceptance::ratio
  /// No vertex of the cavity may lie closer to the circumcentre than this
  /// times the size (the remesher would collapse the edge again).
  double min_dist = 0.6;
  Objective objective = Objective::Alpha;
  const Guard* guard = nullptr;
  const std::atomic<bool>* stop = nullptr;
  /// Threads for the cavity searches made ahead (TopoEditor::plan_points;
  /// 0: every hardware thread); the outcome is the same for every count.
  int threads = 1;
};

struct RefineStats {
  int64_t inserted = 0;  ///< circumcentres inserted
  int64_t tried = 0;     ///< tets whose circumcentre was tried
  /// Cavity searches made ahead in parallel (RefineOptions::threads != 1):
  /// used, and made again because a commit had changed what they read.
  int64_t planned_used = 0, planned_redone = 0;
  /// Windows of the order taken, and their entries pushed back because a
  /// new tet came first (see refine_pass).
  int64_t windows = 0, pushed_back = 0;
  int64_t large = 0;     ///< tets above the ratio at the start
  double seconds = 0;
  Status status;
};

/// Delaunay refinement toward the size field (see RefineOptions).  `h` as
/// in remesh_pass (computed when its size is not m.nv(); extended for every
/// new vertex).  Builds the topology when missing and leaves it current.
RefineStats refine_pass(TetMesh& m, std::vector<double>& h, const RefineOptions& o = {}, const LogFn& log = {});

}  // namespace tetopt
