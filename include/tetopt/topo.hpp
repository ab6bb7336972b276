// tetopt/topo.hpp — topological operations that never touch a constrained face.
//
// Smoothing moves free vertices; it cannot help a tet whose four vertices are
// all constrained (tet_kind == 4, the "all boundary element" of Liu et al.
// 2012, Fig. 1d).  Such a tet can only be removed by changing connectivity.
// This module owns those changes.
//
// Operations.  Every operation replaces a small set of old tets (the
// *cavity*) by new tets that fill exactly the same region:
//   * multi-face removal (Shewchuk 2002, "Two discrete optimization algorithms
//     for the topological improvement of tetrahedral meshes"): two apexes a, b
//     and a triangulated disk of faces sandwiched between them (every disk
//     triangle F has tets F+a and F+b); the 2m tets are replaced by the n
//     tets around the new edge ab, one per disk boundary edge (n = m + 2).
//     The disk is chosen by Shewchuk's tree dynamic program that maximises the
//     worst new quality.  The 2-3 face swap is the case m = 1.
//   * edge removal (George 1995; Shewchuk 2002): an interior edge ab shared
//     by n tets is removed; the ring of n link vertices is triangulated and
//     each triangle gives a tet with a and one with b, 2n - 4 tets in all.
//     The triangulation maximising the worst alpha is found by the O(n^3)
//     polygon dynamic program of Klincsek / Shewchuk 2002.  3-2 is n = 3,
//     4-4 is n = 4 (choice of the ring diagonal).
//   * 2-2: needs an edge shared by exactly two tets, i.e. an edge on the
//     domain boundary whose two boundary faces it would alter; such faces are
//     always constrained, so flip_22 always answers BoundaryLocked (it exists
//     so callers can ask, and tests prove it refuses).
//   Freitag & Ollivier-Gooch 1997 ("Tetrahedral mesh improvement using
//   swapping and smoothing") established 2-3/3-2/edge swapping as the
//   workhorses; Klingner & Shewchuk 2007 ("Aggressive tetrahedral mesh
//   improvement") showed that edge removal plus multi-face removal with
//   optimal choices beats plain flips.  Both are the model for this module.
//
// Every operation runs the same steps: gather the shell / sandwich through the
// tet-tet adjacency (no vertex->tet CSR needed) → build the candidate in
// scratch owned by TopoEditor → exact orient3d of every new tet (must be
// Positive) → quality test (alpha, quality.hpp) against a named margin →
// combinatorial check that the new tets' boundary equals the cavity's
// boundary, face for face and orientation for orientation → commit.  A
// TopoResult says why an operation did not apply.
//
// Invariants (tested): no constrained face (face_mask bit: domain boundary,
// region interface, listed triangle) is removed, split or altered; no edge
// listed in m.edges is removed; no new face equals a listed triangle; no
// vertex moves or disappears; every new tet is exactly positive; new tets take
// the region ref (and Gmsh entity tag) of the tets they replace, and a cavity
// never spans two refs/entities (RegionMismatch).  Total and per-region volume
// are conserved up to rounding.
//
// Bookkeeping.  Inside a TopoEditor session m.tets, tet_ref, tet_entity, adj,
// face_mask and tet_kind are kept right incrementally: a removed tet's slot is
// reused, extra new tets are appended, and removed slots left over are
// tombstones (tets[4t] == -1) until finish() compacts them (swap with last),
// rebuilds the vertex->tet CSR and bumps m.topology_epoch (classify() is not
// re-run: the incremental face_mask / tet_kind equal its answer, tested).  Vertex constraint flags never change (constrained faces
// survive, so their vertices do).  Iteration is in index order: the same input
// gives the same output.
//
// Complexity: one edge removal costs O(n^3) alpha evaluations (n <= 16); a
// pass touches only the tets it is told to (kind 4, or alpha below a
// threshold) plus O(nt) for the alpha cache and the final rebuild.
#pragma once
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "tetopt/guard.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/objective.hpp"
#include "tetopt/status.hpp"

namespace tetopt {

/// Why an operation did or did not apply.
enum class TopoResult {
  Applied,         ///< the mesh was changed (or, from a plan, would be acceptable)
  Inverted,        ///< some new tet would not be exactly positive
  NotImproved,     ///< valid, but fails the quality policy (TopoOptions)
  BoundaryLocked,  ///< would remove or alter a constrained face / listed edge, or create a listed triangle
  ShellTooLarge,   ///< shell or sandwich larger than TopoOptions::max_shell
  RegionMismatch,  ///< the cavity spans two region refs or Gmsh entities
  NotApplicable,   ///< the configuration does not exist (dead tet, bad index, not manifold)
};

/// Short English name of a result ("Applied", "Inverted", ...).
const char* to_string(TopoResult r);

/// Largest shell / ring size any operation accepts (capacity of the scratch).
inline constexpr int kMaxShell = 16;
/// Most tets of a TopoEditor::insert_point cavity.
inline constexpr int kMaxPointCavity = 40;

/// What the operations maximise (the worst value over a cavity's new tets).
enum class TopoMeasure {
  Alpha,     ///< alpha (quality.hpp), the default
  Dihedral,  ///< min over the six dihedral angles of min(theta/dihedral_lo, (180-theta)/(180-dihedral_hi))
};

/// Policy and limits of the topological operations.
struct TopoOptions {
  /// Quality measure the operations and the threshold refer to.
  TopoMeasure measure = TopoMeasure::Alpha;
  /// With TopoMeasure::Alpha: the per-tet quality q (objective.hpp) that
  /// stands for alpha everywhere, alpha_floor included; alpha by default.
  Objective objective = Objective::Alpha;
  /// Guards (guard.hpp): when set, an operation or a relocation is
  /// committed only if every tet it creates passes Guard::admits.  Not
  /// owned; nullptr: no guard.
  const Guard* guard = nullptr;
  /// Abort flag (improve()'s `interrupted`): once set, a pass ends between
  /// two operations or windows of planned ones (every committed one kept).
  /// Not owned; nullptr: never.
  const std::atomic<bool>* stop = nullptr;
  /// A new tet with alpha below this counts as unacceptable (-inf) whatever
  /// the measure: set it to the mesh's worst alpha to make a dihedral pass
  /// that never lowers the worst alpha.
  double alpha_floor = -1e300;
  /// Any measure (0: off): an operation or vertex move may not leave more
  /// tets below this alpha (the objective's q) than it found, nor a worst
  /// below min(the worst it found, this).  alpha_floor alone, set to a worst
  /// alpha that cannot rise (tets on needle boundary triangles), lets a
  /// dihedral pass put new tets just above it beside them; the alpha
  /// measure's flips raise a local worst alpha but may add tets below this.
  double alpha_keep = 0;
  /// Dihedral measure only (0: off): an operation or vertex move may not
  /// leave more tets with a dihedral angle above this (degrees) than it
  /// found, nor a largest angle above max(the largest it found, this).  The
  /// measure rates an angle of 179.5 degrees like one of 0.375: without this
  /// rule a pass would buy a needle tet's smallest angle up from 0.2 to 0.4
  /// degrees with a new tet of 179.5.
  double angle_keep = 0;
  double dihedral_lo = 30.0;   ///< Dihedral measure: target smallest angle (degrees)
  double dihedral_hi = 140.0;  ///< Dihedral measure: target largest angle (degrees)
  /// An operation "improves" when the worst alpha of the new tets exceeds the
  /// worst alpha of the tets it replaces by more than this margin; the margin
  /// stops passes from cycling.
  double margin = 1e-6;
  /// true: every operation must improve (see margin).  false (the paper's
  /// point, §4: the transformation need not improve at once, smoothing the
  /// vertices it brings in does): remove_all_boundary_tets and the single
  /// operations may also accept a change that lowers the number of kind-4
  /// tets in the cavity while the worst alpha drops by at most worsen_bound,
  /// provided every new tet that is still kind 4 (which smoothing cannot fix)
  /// is no worse than the worst tet replaced.  The kind-4 count falls with
  /// every such change, so a pass cannot cycle on them.  flip_pass always
  /// requires improvement.
  bool must_improve = true;
  double worsen_bound = 0.0;  ///< allowed drop of the worst alpha (absolute), see must_improve
  int max_shell = 12;         ///< largest shell / ring / sandwich size tried (<= kMaxShell)
  int passes = 5;             ///< a pass function stops after this many passes or a pass with no change
  /// Passes visit only tets with alpha below this (the paper's gamma, the
  /// set Phi of §2); values above 1 visit every (kind-4) tet.
  double quality_threshold = 0.3;
  bool use_face_swap = true;       ///< 2-3 flips (multi-face removal with one face)
  bool use_edge_removal = true;    ///< edge removal, 3-2 and 4-4 included
  bool use_multi_face = true;      ///< multi-face removal with two or more faces
  /// Threads for the O(nt) set-up loops (the measure cache; 0 = all cores); the operations
  /// themselves run in index order on one thread.  Results do not depend on it.
  int threads = 1;
  /// true: a pass that changed the mesh rebuilds the vertex->tet CSR at its
  /// end.  false: it leaves the CSR empty (vt_offsets and vt_tets cleared)
  /// for a driver that runs several topology passes in a row, which need
  /// adjacency only; smoothing, relax, insertion, untangling and
  /// dihedral_pass rebuild it on entry (ensure_vertex_tets), and so must a
  /// caller that reads stars itself.  improve() runs its topology passes so
  /// (a rebuild costs about 20 ms per 440k tets at 1 thread) and returns the
  /// mesh with the CSR built.
  bool rebuild_stars = true;
};

/// Counters of applied operations.
struct TopoStats {
  int64_t flip23 = 0;               ///< multi-face removals of one face
  int64_t flip32 = 0;               ///< edge removals with n = 3
  int64_t flip44 = 0;               ///< edge removals with n = 4
  int64_t edge_removals = 0;        ///< edge removals with n >= 5
  int64_t multi_face_removals = 0;  ///< multi-face removals of two or more faces
  int64_t flip22 = 0;               ///< always 0 (see flip_22)
  int64_t insertions = 0;           ///< vertices inserted (insert_vertex)
  int64_t removals = 0;             ///< free vertices removed (remove_vertex, collapse_edge)
  int64_t splits = 0;               ///< edges split (split_edge; also counted in insertions)
  int64_t collapses = 0;            ///< edges collapsed (collapse_edge; also counted in removals)
  int64_t pairs = 0;                ///< improve_tet_pair: two-operation changes (each also counted above)
  int64_t all_boundary_removed = 0; ///< operations that removed a kind-4 tet they were aimed at
  int64_t kind4_before = 0, kind4_after = 0;  ///< kind-4 tets before / after the call
  double alpha_worst_before = 0, alpha_worst_after = 0;  ///< over all tets
  int64_t tets_before = 0, tets_after = 0;
  int64_t vertex_moves = 0;         ///< dihedral_pass: free vertices relocated
  int64_t planned_ahead = 0;        ///< improve_tets: options planned in parallel windows (threads > 1)
  int passes = 0;
  double seconds = 0;
  Status status;  ///< not ok when the topology could not be built
  int64_t applied() const {
    return flip23 + flip32 + flip44 + edge_removals + multi_face_removals + flip22 + insertions + removals;
  }
};

/// Acceptance of an operation that need not improve (split_edge,
/// collapse_edge): the new tets' worst quality must be at least
/// max(floor, ratio * min(old worst, cap)), and positive.  Off (the default)
/// admits nothing beyond the editor's own policy.
struct Acceptance {
  bool on = false;
  double floor = 0, cap = 1, ratio = 1;
  explicit operator bool() const { return on; }
  double floor_for(double old_min) const { return std::max(floor, ratio * std::min(old_min, cap)); }
};

/// A session of topological edits on one mesh.  Construction requires the
/// topology (build_topology) to be current; it builds an alpha cache (O(nt)).
/// Tet ids stay stable during the session except that removed tets become
/// tombstones and slots are reused; finish() compacts (ids change) and
/// refreshes the derived topology.  The destructor calls finish() if needed.
/// Not copyable.  All operations of one editor obey its TopoOptions.
class TopoEditor {
 public:
  TopoEditor(TetMesh& m, const TopoOptions& o);
  /// With a caller-owned alpha cache (see flip_pass): used as the measure
  /// cache when the measure is Alpha with no floor and its size is m.nt()
  /// (entries trusted to equal tet_alpha), and handed back by finish(),
  /// compacted with the tets, holding tet_alpha of every tet bit for bit.
  /// Otherwise the cache is cleared and the editor computes its own.
  TopoEditor(TetMesh& m, const TopoOptions& o, std::vector<double>* alpha_cache);
  ~TopoEditor();
  TopoEditor(const TopoEditor&) = delete;
  TopoEditor& operator=(const TopoEditor&) = delete;

  /// 2-3 face swap across face lf (0..3) of tet t.
  TopoResult flip_23(int32_t t, int lf);
  /// 3-2: edge removal of local edge le (0..5) of t when its shell has 3 tets
  /// (NotApplicable otherwise).
  TopoResult flip_32(int32_t t, int le);
  /// 4-4: edge removal of local edge le of t when its shell has 4 tets.
  TopoResult flip_44(int32_t t, int le);
  /// 2-2: always BoundaryLocked (an edge with two tets lies on the boundary)
  /// or NotApplicable (the edge has more tets).
  TopoResult flip_22(int32_t t, int le);
  /// General edge removal of local edge le of t (n = 3..max_shell tets).
  TopoResult remove_edge(int32_t t, int le);
  /// Multi-face removal starting at face lf of t (apex a = vertex lf of t,
  /// apex b = the neighbour's opposite vertex); 2-3 when one face is best.
  TopoResult remove_multi_face(int32_t t, int lf);

  /// A planned operation as remove_edge_judged / remove_face_judged show it
  /// to the caller that decides whether to commit it: the cavity's tets
  /// (old_tets, n_old ids, still in the mesh) and the new tets (quad: n_new
  /// x 4 vertex ids, positively oriented); across[4i+f] is the vertex
  /// opposite face f of new tet i (kFaceVertex[f]) across that face, in a
  /// new tet or in the tet outside the cavity, -1 on the domain boundary.
  struct Planned {
    int n_old = 0, n_new = 0;
    const int32_t* old_tets = nullptr;
    const int32_t (*quad)[4] = nullptr;
    std::vector<int32_t> across;
  };
  /// Returns whether the caller takes the planned operation.
  using Judge = std::function<bool(const Planned&)>;
  /// Edge removal of local edge le of t (3-2, 4-4, n -> 2n-4), and the
  /// removal of face lf of t (2-3 when max_faces is 1, otherwise the best
  /// multi-face removal of at most max_faces faces containing it), for a
  /// caller with its own measure (the face pass, face_pass.hpp): the new
  /// tets are chosen as remove_edge / remove_multi_face choose them (best
  /// worst quality) and checked as they are (exact orientation, the guard,
  /// alpha_floor, constrained faces and listed edges), but need not improve
  /// the quality; the operation is committed when judge says so
  /// (NotImproved when it does not).
  TopoResult remove_edge_judged(int32_t t, int le, const Judge& judge);
  TopoResult remove_face_judged(int32_t t, int lf, int max_faces, const Judge& judge);

  /// Vertex insertion (Klingner & Shewchuk 2007): the cavity is t plus its
  /// neighbours across unconstrained faces of the same region; a new free
  /// vertex (vert_ref 0, appended: existing ids unchanged) is placed by a
  /// compass search maximising the worst alpha of the fan of new tets (new
  /// vertex + each outer face of the cavity) and the fan replaces the cavity
  /// when every new tet is exactly positive and the worst alpha rises by more
  /// than the margin.  Constrained faces stay (they are outer faces).
  /// Alpha measure only (NotApplicable otherwise).
  TopoResult insert_vertex(int32_t t);
  /// insert_vertex on tets[0..n), one by one, later (insert_planned): with
  /// TopoOptions::threads > 1 their position searches, which only read,
  /// run now in parallel on the mesh as it is.  insert_planned(i, t) uses
  /// search i when it was for tet t and no commit since has written a tet
  /// it read (the search would find the same again), and searches again
  /// otherwise: the outcome is insert_vertex's, bit for bit, for every
  /// thread count.  Returns the number planned (0 with one thread).
  int plan_inserts(const int32_t* tets, int n);
  TopoResult insert_planned(int i, int32_t t);
  /// Of the searches plan_inserts made: used by insert_planned, and made
  /// again because a commit had changed what they read.
  int64_t inserts_used() const { return inserts_used_; }
  int64_t inserts_redone() const { return inserts_redone_; }
  /// Vertex removal by edge contraction: for each free vertex v of t and
  /// each vertex w of v's star, the star of v (at most 32 tets, one region
  /// and entity, all positive) is replaced by its tets without w, with v
  /// replaced by w.  Valid when every new tet is exactly positive (w then
  /// sees every face of the star's boundary that it is not on, so the cone
  /// from w fills the star) and the faces match the star's boundary; taken
  /// when the worst alpha of the star rises by more than the margin (best
  /// (v, w) wins).  Constrained faces are never removed (v is on none).  v
  /// stays in the vertex array, referenced by no tet, and is appended to
  /// removed(); see compact_vertices (mesh.hpp).  Alpha measure only.
  TopoResult remove_vertex(int32_t t);
  /// Edge split (the remesher's refinement, remesh_pass in insert.hpp): the
  /// shell of local edge le of t, an edge on no constrained face and not
  /// listed, is replaced by the cone from a new free vertex p (appended, as
  /// insert_vertex) over the shell's outer faces, 2n tets for a shell of n.
  /// p is wa * a + (1 - wa) * b, moved by a short compass search when that
  /// point leaves a new tet below acc's floor.  Taken when every new tet is
  /// exactly positive, passes the guards and acc admits the new worst (not
  /// necessarily above the old worst: the caller chooses).  Alpha
  /// measure only.
  TopoResult split_edge(int32_t t, int le, const Acceptance& acc, double wa = 0.5);
  /// Point insertion by a Bowyer-Watson cavity (the remesher's refinement,
  /// refine_pass in insert.hpp; Bowyer 1981, Watson 1981; Shewchuk's
  /// Delaunay refinement inserts circumcentres so): x is located by a walk
  /// from t across unconstrained faces of t's region (refused when the walk
  /// meets a constrained face, the domain boundary or another region); the
  /// cavity is the containing tet plus the tets of the region reached across
  /// unconstrained faces whose circumsphere holds x (at most
  /// kMaxPointCavity), shrunk until x sees every outer face (exact
  /// orient3d), so the cone from a new free vertex at x (appended, as
  /// insert_vertex) over the outer faces fills it.  Every cavity vertex
  /// stays on an outer face and no listed edge or triangle vanishes.  Taken
  /// when the new tets pass the guards and acc admits their worst quality.
  /// Refused (NotApplicable) when a vertex of the cavity lies closer to x
  /// than min_dist.  `made`, when given, receives the new tets' ids.  Alpha
  /// measure only.
  TopoResult insert_point(int32_t t, const double* x, const Acceptance& acc, double min_dist = 0,
                          std::vector<int32_t>* made = nullptr);
  /// insert_point on (tets[i], x + 3i, acc, min_dist[i]), i < n, one by one
  /// later, in any order (insert_point_planned), as plan_inserts does for
  /// insert_vertex: with TopoOptions::threads > 1 the cavity searches run
  /// now, in parallel, except for a tet planned before with the same point
  /// and distance and not used since.  insert_point_planned uses a tet's
  /// search when it was for the same point and distance and no commit since
  /// has written a tet it read, and searches again otherwise (also when
  /// given another acc than the search's).  Returns the number of searches
  /// made.
  int plan_points(const int32_t* tets, const double* x, const double* min_dist, int n, const Acceptance& acc);
  TopoResult insert_point_planned(int32_t t, const double* x, const Acceptance& acc, double min_dist,
                                  std::vector<int32_t>* made = nullptr);
  /// True when tet t has a search of plan_points not yet used, made while
  /// slot t held the tet it holds now.
  bool point_planned(int32_t t) const;
  /// Threads the searches made ahead (plan_inserts, plan_points,
  /// improve_tets) use for TopoOptions::threads = requested: 1 without
  /// oneTBB or with one hardware thread.
  static int plan_threads(int requested);
  int64_t points_used() const { return points_used_; }      ///< searches of plan_points used
  int64_t points_redone() const { return points_redone_; }  ///< and made again
  /// Edge collapse: remove_vertex restricted to the contraction of one
  /// endpoint of local edge le of t (a free one; a first, then b) onto the
  /// other, taken when acc admits the new tets' worst quality; only a
  /// vertex with id >= removable_from may go.  The removed
  /// vertex is appended to removed().
  TopoResult collapse_edge(int32_t t, int le, const Acceptance& acc, int32_t removable_from = 0);
  /// Vertices removed by remove_vertex, in order.
  const std::vector<int32_t>& removed() const { return removed_; }
  /// Algorithm 4 of Liu et al. on one tet: tries edge removal on each of
  /// t's edges, face swaps and multi-face removals across its unconstrained
  /// faces, and commits the acceptable option with the best worst alpha
  /// (ties: fewer kind-4 tets, then the first tried).  strict: demand
  /// improvement even when TopoOptions::must_improve is false (flip_pass).
  /// Returns Applied, or the most telling refusal among the options.
  TopoResult improve_tet(int32_t t, bool strict);
  /// improve_tet, and where no single operation improves t, a search of
  /// depth two: every valid operation on t and on the tets within `reach`
  /// face-to-face steps of it (edge removal of each edge, face swap and
  /// multi-face removal across each free face; reach 1: t and its four
  /// neighbours, about 70 options) is applied even when it lowers the worst
  /// alpha, followed by the best improving operation on t or on one of its
  /// new tets that is no better than the tets the first replaced;
  /// the pair whose result has the highest worst alpha is kept when that
  /// exceeds the worst alpha of every tet the pair replaced by the margin,
  /// and everything else is undone.  Escapes the local optimum of single
  /// flips where an all-boundary sliver can only go by way of a worse
  /// intermediate (e.g. a 4-4 flip that creates the edge a 2-3 flip then
  /// completes).  Alpha measure only; about 100 times the cost of improve_tet at reach 1.
  TopoResult improve_tet_pair(int32_t t, int reach = 1);
  /// improve_tet on every tet of `work`, in order, that is alive, below
  /// `threshold` and (kind4_only) of kind 4 when its turn comes; returns the
  /// number applied.  With TopoOptions::threads > 1 the options of a window
  /// of tets are planned in parallel on the mesh as it was when the window
  /// began, then committed in order; a plan is used only when no commit of
  /// the window touched a tet it read (otherwise the tet is planned again),
  /// so the result is the serial loop's, bit for bit, for every thread count.
  int64_t improve_tets(const std::vector<int32_t>& work, bool strict, bool kind4_only, double threshold);

  bool alive(int32_t t) const;      ///< t is a live tet (not a tombstone)
  const TopoOptions& options() const { return o_; }  ///< the options the editor was opened with
  /// The option's measure of tet (a, b, c, d) (alpha by default), -inf below
  /// TopoOptions::alpha_floor.  cached_alpha() holds this measure.
  double quality(const double* a, const double* b, const double* c, const double* d) const;
  double cached_alpha(int32_t t) const {
    const double a = alpha_[t];
    return a == a ? a : deferred(t);
  }
  /// cached_alpha(t) < thr, without computing a deferred dihedral measure
  /// whose lower bound already answers no.
  bool below(int32_t t, double thr) const {
    const double a = alpha_[t];
    if (a == a) return a < thr;
    if (lb_[t] >= thr) return false;
    return deferred(t) < thr;
  }
  /// Smallest cached measure over the live tets (deferred entries are
  /// computed only when their lower bound could beat the minimum; a free
  /// slot's entry is +inf).
  double min_cached() const;
  /// True when some measures are deferred (see fill_cache): then below() and
  /// cached_alpha() may write the cache and must not run concurrently.
  bool deferring() const { return !lb_.empty(); }
  /// Starts a new change epoch and returns it: every commit stamps the
  /// vertices of its new tets, and every tet slot it writes (new, removed,
  /// or an outer neighbour whose link it updates), with the current epoch.
  uint32_t next_stamp() { return ++stamp_; }
  /// True when a commit since epoch s (inclusive) created a tet sharing a
  /// vertex with live tet t, i.e. t's edge shells may have changed.
  bool touched_since(int32_t t, uint32_t s) const {
    const int32_t* v = m_.tet(t);
    return vstamp_[v[0]] >= s || vstamp_[v[1]] >= s || vstamp_[v[2]] >= s || vstamp_[v[3]] >= s;
  }
  const TopoStats& stats() const { return stats_; }
  TopoStats& stats() { return stats_; }
  /// Compacts tombstones (moving face_mask / tet_kind along: commit keeps them
  /// right, so classify() is not re-run), rebuilds the vertex->tet CSR, bumps
  /// topology_epoch.  Idempotent; the editor must not be used afterwards.
  void finish();

  struct Candidate;  // scratch (defined in topo.cpp)

 private:
  // Planning never writes the mesh or the editor (const; with a deferred
  // dihedral measure cached_alpha() fills the mutable cache).  `reads`, when
  // given, receives the id of every tet the plan read (vertices, links,
  // masks, refs or cached measure; see improve_tets).
  TopoResult plan_edge(int32_t t, int le, int want_n, bool strict, Candidate& c, double bound,
                       std::vector<int32_t>* reads) const;
  TopoResult plan_multi(int32_t t, int lf, int max_tris, bool strict, Candidate& c,
                        std::vector<int32_t>* reads) const;
  TopoResult finish_plan(bool strict, Candidate& c) const;
  // The shell of local edge le of t: endpoints a, b, ring r_0..r_n-1 and
  // shell tets (a, b, r_i, r_i+1), each positively oriented, n <= max_shell;
  // refuses an edge on a constrained face, a listed edge or a boundary edge.
  TopoResult gather_shell(int32_t t, int le, int32_t& a, int32_t& b, int32_t* ring, int32_t* shell, int& n,
                          std::vector<int32_t>* reads) const;
  // The tets an operation replaces: c's old tets, their worst measure and
  // their kind-4 count.
  void set_old_tets(Candidate& c, const int32_t* tets, int n) const;
  // insert_vertex / insert_point: the cone from a new free vertex at x over
  // outer faces face[0..nf) (in their tets' kFaceVertex order, outward),
  // planned into c (its old tets set) and committed; the vertex is taken
  // back when the plan fails.  `made`, when given, receives the new tets.
  TopoResult commit_cone(Candidate& c, const double* x, const int32_t (*face)[3], int nf,
                         std::vector<int32_t>* made);
  // insert_vertex = search_insert (the cavity and place, read only; `reads`
  // as for plan_best) + insert_found (plan and commit the cone).
  struct InsertSearch;  // defined in topo.cpp
  struct InsertPlans;
  void search_insert(int32_t t, InsertSearch& s, std::vector<int32_t>* reads) const;
  TopoResult insert_found(int32_t t, InsertSearch& s);
  // True when no commit since epoch has written any of the tets `reads`.
  bool unchanged_since(const std::vector<int32_t>& reads, uint32_t epoch) const;
  // The scratch candidate of an insertion at tet t replacing old[0..n).
  Candidate& cone_candidate(int32_t t, const int32_t* old, int n);
  // insert_point = search_point (the cavity, read only; the marks are the
  // caller's) + point_found (plan and commit the cone).
  struct PointSearch;
  struct PointPlans;
  TopoResult search_point(int32_t t, const double* x, const Acceptance& acc, double min_dist, PointSearch& s,
                          std::vector<uint32_t>& mark, uint32_t& mark_epoch, std::vector<int32_t>* reads) const;
  TopoResult point_found(int32_t t, const double* x, const Acceptance& acc, PointSearch& s,
                         std::vector<int32_t>* made);
  PointSearch* psearch_ = nullptr;
  PointPlans* pplans_ = nullptr;
  int64_t points_used_ = 0, points_redone_ = 0;
  InsertSearch* isearch_ = nullptr;  // insert_vertex's scratch
  InsertPlans* iplans_ = nullptr;    // plan_inserts' searches
  int64_t inserts_used_ = 0, inserts_redone_ = 0;
  // insert_vertex: when the guard refuses the cone from x over face[0..nf),
  // moves x to a nearby position where every cone tet has q > need and the
  // guard admits it; false (x unchanged) when none was found.
  bool guarded_position(const int32_t (*face)[3], int nf, double need, double* x) const;
  // The tet across face f of o when a cavity may grow into it: the face
  // unconstrained, the tet alive, of region ref (and Gmsh entity); else -1.
  int32_t joinable_nb(int32_t o, int f, int32_t ref, int32_t entity) const;
  // insert_vertex / split_edge: append a free vertex at x (its id), take it back.
  int32_t push_vertex(const double* x);
  void pop_vertex();
  // remove_vertex's contraction, limited to vertex only_v onto only_w (-1: any).
  TopoResult contract(int32_t t, int32_t only_v, int32_t only_w);
  Acceptance accept_;  // finish_plan also accepts what accept_ admits (split / collapse)
  // improve_tet without the commit: the chosen option ends in *best (the two
  // scratch pointers are swapped while options are compared).  Options whose
  // worst new alpha does not exceed `floor` are refused.
  TopoResult plan_best(int32_t t, bool strict, Candidate*& cand, Candidate*& best,
                       std::vector<int32_t>* reads, double floor = -std::numeric_limits<double>::infinity()) const;
  // Writes the new tets of c; `slots`, when given, receives their ids.
  // counted: add the operation to stats() (an undo of a trial is not).
  void commit(const Candidate& c, int32_t* slots = nullptr, bool counted = true);
  void count(const Candidate& c);
  bool any_valid_ = false;            // finish_plan accepts every valid option (improve_tet_pair)
  bool judged_ = false;               // the caller judges: every valid, admitted option (remove_*_judged)
  TopoResult judge_plan(TopoResult r, const Judge& judge);
  bool restoring_ = false;            // finish_plan plans an undo: no policy, no orientation test
  std::vector<Candidate> trial_;      // improve_tet_pair's first operations (allocated on first use)
  std::vector<int32_t> around_;       // improve_tet_pair's tets near t
  std::vector<uint32_t> mark_;        // insert_point's per-tet marks (seen, in the cavity)
  uint32_t mark_epoch_ = 0;

  double deferred(int32_t t) const;
  // Set while improve_tets plans in parallel: deferred() then computes a
  // measure without storing it (the threads would race on the cache; the
  // number is the same either way, so only the cost differs).  Which
  // deferred measures end up stored then depends on the thread count;
  // below() and min_cached() give the same answers either way because lb_
  // is a true lower bound (Topo.DihedralMeasureDeferralIsALowerBound).
  bool nocache_ = false;
  void fill_cache();

  TetMesh& m_;
  TopoOptions o_;
  // Per-tet measure.  With the dihedral measure a tet whose alpha proves its
  // measure >= the pass threshold is deferred: NaN here, the proven lower
  // bound in lb_, computed on first use (see the constructor).
  mutable std::vector<double> alpha_;
  std::vector<double> lb_;
  std::vector<double>* shared_ = nullptr;  // caller's alpha cache, given back by finish()
  std::vector<int32_t> free_;
  std::vector<int32_t> removed_;  // vertices removed by remove_vertex
  std::vector<uint32_t> vstamp_;  // per vertex: epoch of the last commit touching it
  std::vector<uint32_t> tstamp_;  // per tet slot: epoch of the last commit writing it
  uint32_t stamp_ = 1;
  std::vector<uint64_t> listed_edges_;
  std::vector<int32_t> own_tri_keys_;  // when the mesh's tri_keys are not built
  const std::vector<int32_t>* listed_tris_ = nullptr;  // sorted triples, flattened (TetMesh::tri_keys)
  Candidate* cand_ = nullptr;         // two scratch candidates (current, best)
  Candidate* best_ = nullptr;
  TopoStats stats_;
  bool finished_ = false;
};

/// Single operations on a mesh with current topology.  Each opens a
/// TopoEditor, applies one operation and finishes (O(nt) per call: use a
/// TopoEditor or a pass for bulk work).  Tet ids may change when a tet is
/// removed (3-2, multi-face removal).
TopoResult flip_23(TetMesh& m, int32_t t, int lf, const TopoOptions& o = {});
TopoResult flip_32(TetMesh& m, int32_t t, int le, const TopoOptions& o = {});
TopoResult remove_edge(TetMesh& m, int32_t t, int le, const TopoOptions& o = {});
TopoResult remove_multi_face(TetMesh& m, int32_t t, int lf, const TopoOptions& o = {});

/// Liu et al. 2012 Algorithm 4 over every all-boundary tet (tet_kind == 4)
/// with alpha below o.quality_threshold, in index order, repeated for o.passes passes or until a pass changes nothing.  Builds the
/// topology first if it is missing.  Policy: o.must_improve / worsen_bound.
TopoStats remove_all_boundary_tets(TetMesh& m, const TopoOptions& o = {}, const LogFn& log = {});

/// Dihedral pass: up to o.passes rounds of (flip_pass with o.measure =
/// Dihedral and, when o.alpha_floor is left at its default, alpha_floor = the
/// mesh's current worst alpha; an explicit floor trades worst alpha down to
/// it for angles) then relocation of the free vertices of tets
/// still below o.quality_threshold (compass search maximising the star's
/// worst dihedral measure, exact orient3d before commit), until a round
/// changes nothing.  The measure is 1 when a tet's extreme angles sit at
/// dihedral_lo / dihedral_hi, so a threshold of 1 visits every tet short of
/// the targets.  Raises the smallest / lowers the largest dihedral angles and
/// never lowers the worst alpha (every new or moved tet keeps alpha >= the
/// floor, by default the worst alpha before the pass); constrained vertices and faces are untouched.  Stats' alpha fields
/// hold the dihedral measure; vertex_moves counts relocations.  Requires the
/// topology (builds it if missing).
TopoStats dihedral_pass(TetMesh& m, const TopoOptions& o = {}, const LogFn& log = {});

/// Quality-driven pass: for every tet with alpha below o.quality_threshold
/// (index order), commits the best operation touching it that raises the
/// worst alpha of its cavity by more than o.margin.
TopoStats flip_pass(TetMesh& m, const TopoOptions& o = {}, const LogFn& log = {});

/// remove_all_boundary_tets and flip_pass with a caller-owned per-tet alpha
/// cache shared with smooth_pass (smooth.hpp): when its size is m.nt() its
/// entries are trusted to equal tet_alpha(m, t), otherwise it is filled; on
/// return it holds tet_alpha(m, t) of the new tets, bit for bit.  Saves the
/// O(nt) quality evaluation of every pass.  nullptr: as above.
TopoStats remove_all_boundary_tets(TetMesh& m, const TopoOptions& o, const LogFn& log,
                                   std::vector<double>* alpha_cache);
TopoStats flip_pass(TetMesh& m, const TopoOptions& o, const LogFn& log, std::vector<double>* alpha_cache);

/// improve_tet_pair on the tets with alpha below min(o.quality_threshold,
/// worst alpha + band), worst first (ties: lower index), at most max_tets of
/// them per pass (< 0: no limit), serially (the output does not depend on
/// o.threads); passes repeat, with the band above the new worst alpha, for
/// o.passes passes or until a pass changes nothing or (stop_at_worst) no
/// longer raises the worst alpha.  stop_at_worst also gives the worst tet of
/// the mesh, when reach 1 fails on it and it is all-boundary (kind 4: only
/// topology can help it), a search at reach 2 (about 17 tets), and ends the
/// pass when that fails too: the rest of the pass could not raise the worst
/// alpha.  Meant for the few worst tets
/// that flip_pass leaves: a visit costs about 100 flip_pass visits.  Alpha
/// measure only; alpha_cache as above.
TopoStats pair_flip_pass(TetMesh& m, const TopoOptions& o, double band, int64_t max_tets = -1,
                         bool stop_at_worst = false, const LogFn& log = {},
                         std::vector<double>* alpha_cache = nullptr);

}  // namespace tetopt
