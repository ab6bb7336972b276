// tetopt/relax.hpp — global relaxation for globally bad meshes.
//
// What this module owns
//   The smoothing and flipping passes of smooth.hpp / topo.hpp are local:
//   they repair a few poor tets in an otherwise decent mesh.  A mesh made by
//   lazy random insertion (every vertex only splits the tet that holds it,
//   like the RAND meshes of Freitag & Ollivier-Gooch 1997) is bad
//   everywhere, and its boundary triangles can be far larger than the
//   spacing of the free vertices, so free vertices must travel many
//   spacings (away from the big constrained faces) before any local
//   optimiser can make the tets on those faces good.  relax_pass moves every
//   free vertex at once, many times, with flips in between.
//
// The method (a density-weighted centroidal relaxation, after the
//   mesh-smoothing view of centroidal Voronoi / optimal Delaunay
//   tessellations: Du, Faber & Gunzburger 1999; Chen & Xu 2004; Alliez,
//   Cohen-Steiner, Yvinec & Desbrun 2005, "Variational tetrahedral meshing")
//   1. Size field.  Every constrained face f gets h_f = its mean edge
//      length.  A vertex gets h(v) = max(h_min, h_f - g * dist(v, f)) for the
//      face f propagated to it by a multi-source Dijkstra over mesh edges
//      (largest value first, each vertex inheriting the face of the
//      neighbour that reached it: the feature-propagation approximation of
//      max over all f, O(E log V)); g = RelaxOptions::gradation; h_min is the
//      spacing the free vertices would have if spread evenly,
//      (domain volume / free vertices)^(1/3).  Density rho = h^-3: large
//      constrained faces ask for sparse vertices near them.
//   2. Relaxation (Jacobi).  Each free vertex v goes to
//      x* = sum_T w_T g_T / sum_T w_T over its star, g_T the centroid of T and
//      w_T = |T| * rho_T (rho_T from the mean h of T's vertices): the
//      mass-weighted centroid of its star, the discrete Lloyd step
//      with density rho.  All vertices move by step * (x* - x) together.
//   3. Validation.  Every tet touched by a moved vertex must stay Positive
//      under the exact orient3d and keep alpha >= min(alpha before,
//      alpha_floor).  Free vertices of failing tets are put back, and the
//      check repeats until nothing fails (a put-back tet is its old, valid
//      self); put-back vertices are retried with half the step, twice.
//   4. Connectivity.  Every `steps` Jacobi steps, flip_pass (topo.hpp) with a
//      threshold above 1 visits every tet and commits the 2-3 / 3-2 / edge
//      removal / multi-face removal that raises the worst alpha of its
//      cavity, never touching a constrained face.
//   Constrained vertices never move; constrained faces are never removed
//   (flip_pass guarantees it); no tet is ever made non-positive.
//
// When to call it (relax_wanted): only for globally bad meshes, measured as
//   the fraction of tets with alpha < 0.1 being at least `trigger_fraction`
//   (default 0.25).  Good meshes (few bad tets) are left to the local passes.
//
// Cost: O(nt) per Jacobi step (plus O(E log V) for the size field, rebuilt
//   after each flip pass), plus flip_pass; single-threaded, deterministic.
#pragma once
#include <cstdint>
#include <vector>

#include "tetopt/guard.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/status.hpp"

namespace tetopt {

struct RelaxOptions {
  int rounds = 15;              ///< rounds of (steps Jacobi steps, one flip pass)
  int steps = 4;                ///< Jacobi relaxation steps per round
  double step = 0.7;            ///< fraction of the way to the weighted centroid moved per step
  double gradation = 1.0;       ///< g: how fast the size field falls away from constrained vertices
  double alpha_floor = 0.02;    ///< a move may not push a tet below min(its alpha, this)
  double flip_threshold = 1.1;  ///< flip_pass visits tets with alpha below this (> 1: all)
  double trigger_fraction = 0.25;  ///< relax_wanted: fraction of tets with alpha < 0.1
  double min_gain = 1e-3;       ///< stop when a round raises the mean alpha by less than this
  const Guard* guard = nullptr;  ///< guards (guard.hpp) for the moves and flips; nullptr: none
  /// Threads of the flip passes (TopoOptions::threads: their options are
  /// planned in parallel and committed in order, the same flips for every
  /// count); the Jacobi steps run on one.
  int threads = 1;
};

struct RelaxStats {
  int rounds = 0;
  int64_t moves = 0;            ///< accepted vertex moves (summed over steps)
  int64_t put_back = 0;         ///< vertex moves undone by the validation
  int64_t flips = 0;            ///< topological operations applied by the flip passes
  double alpha_worst_before = 0, alpha_worst_after = 0;
  double alpha_mean_before = 0, alpha_mean_after = 0;
  double seconds = 0;
  Status status;                ///< not ok when a flip pass failed to rebuild topology
};

/// Fraction of tets with alpha < 0.1 (0 for an empty mesh); counted in
/// blocks on `threads` threads (0 = all cores), the same for every count.
double bad_tet_fraction(const TetMesh& m, int threads = 1);

/// True when the mesh is globally bad enough for relax_pass
/// (bad_tet_fraction(m, threads) >= o.trigger_fraction).
bool relax_wanted(const TetMesh& m, const RelaxOptions& o = {}, int threads = 1);

/// Size field of step 1 of the essay (one value per vertex, at least h_min;
/// unused vertices 0).
/// Requires m's topology.
std::vector<double> relax_size_field(const TetMesh& m, double gradation);

/// The global relaxation of the essay.  Requires m's topology; leaves it
/// current.  Logs one Progress line per round through `log`.
RelaxStats relax_pass(TetMesh& m, const RelaxOptions& o = {}, const LogFn& log = {});

}  // namespace tetopt
