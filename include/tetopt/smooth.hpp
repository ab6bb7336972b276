// tetopt/smooth.hpp — optimisation-based vertex smoothing with the paper's
// boundary weight C (Liu, Dai, Dong, Tan 2012, §3).
//
// What this module owns
//   Moving free (unconstrained) vertices to better positions.  Connectivity is
//   never changed, so the vertex->tet CSR built by build_topology() stays
//   valid; constrained vertices (TetMesh::vert_constrained) never move, bit for
//   bit.
//
// The local objective (paper eqs. 3.2 and 3.4)
//   For a free vertex v with star S(v) (the tets that contain v):
//       f_v(x) = (1 - C) * sum_{T in S(v), interior} e(T)
//              +      C  * sum_{T in S(v), boundary} e(T)
//   with e(T) = 1/alpha(T) = (sum of face areas * longest edge) / (6 sqrt6 V),
//   +infinity when V <= 0 in floating point.  "Boundary" means a tet with at
//   least one constrained vertex (TetMesh::tet_kind[t] > 0, paper Fig. 1).
//   0.5 <= C < 1; C = 0.5 weighs every tet alike (plain smoothing).  f is
//   invariant under translation and uniform scaling of the star, and scaling
//   the weights by a power of two changes nothing bit for bit.
//
// Two optimisers (Optimizer)
//   Paper   f is not smooth (the longest edge of a tet switches), so each step
//           takes the steepest-descent direction of f with every tet's current
//           longest edge held (analytic gradient, tet_error_and_gradient), then
//           brackets a minimum along it with the advance-retreat interval
//           search (paper Alg. 3) and narrows it with golden section (Alg. 2)
//           to line_tol times the star's mean edge length.  Steps repeat until
//           max_steps or a step gains less than step_tol (relative).
//   MaxMin  Freitag, Jones & Plassmann 1995 / Freitag & Ollivier-Gooch 1997:
//           maximise the worst alpha of the star.  Each step takes the
//           tets whose alpha is within active_tol of the worst (at most 8),
//           finds the steepest common ascent direction (the minimum-norm point
//           of the convex hull of their gradients, by enumerating faces of at
//           most three gradients), predicts the step where an inactive tet
//           would become the worst, and halves it until the worst alpha
//           really rises.  MaxMin ignores the weight C.
//
// Commit rule (both optimisers; STYLE.md §5)
//   A candidate position is committed only if (1) every tet of the star is
//   Positive under the exact predicate orient3d, (2) the objective improves
//   by at least the named relative `margin` (Paper: f_new <= f_old*(1-margin);
//   MaxMin: worst alpha rises by margin*worst), and (3) when protect_worst is
//   set (default), the star's worst alpha — computed by tetopt::alpha() on the
//   absolute coordinates, the same function compute_stats uses — does not
//   decrease.  If a candidate fails, it is pulled halfway back to the old
//   position up to four times before the move is rejected.  Because every
//   commit lowers f_v by the margin (and, with protect_worst, never lowers the
//   star's worst alpha), passes cannot cycle and the mesh's worst alpha is
//   non-decreasing.
//
// Passes (smooth_pass; paper §2 steps 2-3)
//   Phase 1: the active set is every free vertex of a tet with alpha < the
//   threshold gamma, visited in an order shuffled by std::mt19937_64(seed)
//   (own Fisher-Yates, so the order does not depend on the standard library).
//   After a sweep, the next active set is the free vertices of tets around the
//   vertices that moved (by a gain of at least reactivate_gain) that still
//   touch a tet with alpha < gamma (vertices whose star did not change would
//   give the same answer again).  Phase 1 ends
//   after `iterations` sweeps or when a sweep moves nothing.  Phase 2 (only
//   with all_vertices) does the same over every free vertex without the alpha
//   filter, with its own budget of `iterations` sweeps.  Output is a pure
//   function of the input mesh and options: the same seed gives byte-identical
//   coordinates, for every thread count.
//
// Parallel sweeps (Jones & Plassmann 1993, "A parallel graph coloring
//   heuristic"; Freitag, Jones & Plassmann 1999, "A parallel algorithm for
//   mesh smoothing").  Each sweep colours the active vertices greedily in
//   the shuffled order (smallest colour not taken by an already coloured
//   active vertex sharing a tet), then runs the colour classes one after
//   another, each class in its shuffled order.  Two vertices of one class
//   share no tet, so neither solve reads what the other writes: a class may
//   run on any number of threads (SmoothOptions::threads) and the result is
//   the same bytes as with one.  (It is a different Gauss-Seidel order from
//   visiting the shuffled list directly, which is why the colouring is used
//   for one thread too.)
//
// Cost
//   One objective evaluation is O(|S(v)|) with no allocation: the star is
//   gathered once per vertex solve into thread-local scratch buffers that only
//   grow (coordinates relative to the vertex, the constant opposite-face
//   normal and longest fixed edge precomputed).  smooth_pass keeps a
//   per-tet alpha cache: one O(nt) alpha evaluation to fill it (none when the
//   caller hands in a current cache), then only the stars of committed moves
//   are re-evaluated (the commit check's own alpha values are stored, bit for
//   bit what tet_alpha() gives).  Beyond that a pass costs a few O(nt) scans
//   of the cache (poor-tet filter, worst alpha, the objective sum) plus
//   O(sum of star sizes of active vertices) per sweep, spread over the
//   threads.  smooth_vertex may be called concurrently from several threads
//   on vertices that share no tet.
//
// Preconditions: build_topology(m) succeeded and the mesh has not changed
// connectivity since.  Tets should be positive; a vertex whose star contains
// a flat or inverted tet (f infinite) is left where it is (Inverted).
#pragma once
#include <atomic>
#include <cstdint>
#include <vector>

#include "tetopt/guard.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/objective.hpp"
#include "tetopt/status.hpp"

namespace tetopt {

/// Local optimiser used by smooth_vertex (see the essay above).
enum class Optimizer {
  Paper,   ///< descent on the weighted sum f_v, bracketing + golden section (paper §3.2)
  MaxMin,  ///< Freitag's nonsmooth max-min on the star's worst alpha (weight ignored)
  SmartLaplace,  ///< one candidate: the mean of the star's other vertices, kept when f_v falls
};

/// Outcome of one smooth_vertex call.
enum class SmoothResult {
  Applied,         ///< the vertex moved; the objective improved by at least the margin
  NotImproved,     ///< no position better by the margin was found; vertex unchanged
  BoundaryLocked,  ///< the vertex is constrained (or used by no tet); unchanged
  Inverted,        ///< every improving candidate inverted or flattened a tet under
                   ///< orient3d, or the star is already invalid; vertex unchanged
};

struct SmoothOptions {
  double weight = 0.75;        ///< C of eq. 3.4, in [0.5, 1); clamped to that range
  double threshold = 0.3;      ///< gamma: vertices of tets with alpha < gamma are active
  int iterations = 10;         ///< max sweeps per phase (n of paper §2)
  Optimizer optimizer = Optimizer::Paper;
  uint64_t seed = 0;           ///< seeds the visiting order (std::mt19937_64)
  bool all_vertices = false;   ///< after the poor-tet phase, sweep every free vertex
  double margin = 1e-9;        ///< relative improvement a committed move must bring
  bool protect_worst = true;   ///< also reject moves that lower the star's worst alpha
  double line_tol = 1e-2;      ///< epsilon of Alg. 2, relative to the star's mean edge length (finer: measured gain < 1e-4 of f)
  double step_tol = 1e-4;      ///< stop descending when a step gains less (relative)
  int max_steps = 8;           ///< descent steps per vertex solve
  double active_tol = 1e-3;    ///< MaxMin: tets within this (relative) of the worst are active
  /// A committed move re-activates its neighbours for the next sweep only if
  /// it improved the vertex's own objective (Paper: f_v; MaxMin: the star's
  /// worst alpha) by at least this fraction; smaller moves do not start a
  /// new wave of work.  0 re-activates after every move.
  double reactivate_gain = 1e-3;
  /// Worker threads for the colour classes and the initial alpha scan;
  /// 0 = std::thread::hardware_concurrency().  The result does not depend on
  /// it (byte-identical coordinates for every value).
  int threads = 1;
  /// What q the objective's e = 1/q and the max-min's worst measure are
  /// (objective.hpp); alpha by default, the paper's.  Other objectives take
  /// their gradients by central differences.
  Objective objective = Objective::Alpha;
  /// Guards (guard.hpp): when set, a move is committed only if no tet of
  /// the star at the new position is worse than the guard's extremes on a
  /// guarded measure.  Not owned; nullptr: no guard.
  const Guard* guard = nullptr;
  /// Abort flag (improve()'s `interrupted`): once set, the pass ends
  /// between two colour classes of a sweep (every committed move kept).
  /// Not owned; nullptr: never.
  const std::atomic<bool>* stop = nullptr;
};

/// Counters and measurements of one smooth_pass.
struct SmoothStats {
  int64_t moves_tried = 0;      ///< smooth_vertex calls on free vertices
  int64_t moves_applied = 0;    ///< ... that returned Applied
  int64_t not_improved = 0;     ///< ... NotImproved
  int64_t rejected_inverted = 0;  ///< ... Inverted
  int64_t initial_active = 0;   ///< size of the first active set (phase 1)
  int sweeps = 0;               ///< sweeps run, both phases together
  double seconds = 0;           ///< wall time of the whole pass
  /// f of eq. 3.4 before and after: sum over tets of w_T / alpha_T from the
  /// pass's alpha cache, in tet order (mesh_objective up to rounding).
  double objective_before = 0;
  double objective_after = 0;
  double worst_alpha_before = 0;  ///< min over tets of tetopt::alpha
  double worst_alpha_after = 0;
};

/// f_v of eq. 3.4 at v's current position: the weighted sum of e(T) over v's
/// star (interior tets weighted 1 - weight, boundary tets weight).  +inf when
/// a star tet is flat or inverted in floating point.  Works for constrained
/// vertices too (it only reads).  Requires m's topology.
double vertex_objective(const TetMesh& m, int32_t v, double weight);

/// f(Γ) of eq. 3.4 over the whole mesh (deterministic order).  Requires m's
/// topology (tet_kind).
double mesh_objective(const TetMesh& m, double weight);

/// e(T) = 1/alpha of the tet (p[0], p[1], p[2], p[3]) (each 3 doubles, positive
/// orientation as in conventions.hpp) and, in grad, its analytic gradient with
/// respect to the coordinates of p[which] (0..3) with the tet's current
/// longest edge held fixed (exact wherever the longest edge is unique).
/// Returns +inf and a zero gradient when the signed volume is <= 0.
double tet_error_and_gradient(const double* const p[4], int which, double grad[3]);

/// Optimises the position of vertex v alone (see the essay: optimisers and
/// commit rule).  Only m.xyz of v may change.  Requires m's topology.
SmoothResult smooth_vertex(TetMesh& m, int32_t v, const SmoothOptions& o);

/// The paper's smoothing passes over the whole mesh (see the essay: passes).
/// Reports one Progress line per sweep through `log` when given.  Requires
/// m's topology; leaves it valid.
SmoothStats smooth_pass(TetMesh& m, const SmoothOptions& o, const LogFn& log = {});

/// The same pass with a per-tet alpha cache owned by the caller, so that
/// consecutive passes (and the caller's own worst-alpha checks) need no O(nt)
/// quality evaluation.  When alpha_cache->size() == m.nt() its entries must
/// equal tet_alpha(m, t) (they are trusted); otherwise it is filled.  On
/// return it holds tet_alpha(m, t) for every tet, bit for bit.  Invalidate it
/// (clear()) after any change of connectivity or coordinates made elsewhere.
/// nullptr behaves like the overload above.
SmoothStats smooth_pass(TetMesh& m, const SmoothOptions& o, const LogFn& log, std::vector<double>* alpha_cache);

}  // namespace tetopt
