// tetopt/untangle.hpp — repairing inverted and flat input tets by moving
// free vertices.
//
// What this module owns
//   A mesh may arrive tangled: some tets inverted (negative exact
//   orientation) or flat (zero).  Smoothing cannot start from such a star
//   (its objective is infinite there), so untangle() runs first and moves
//   unconstrained vertices of non-positive tets to make them positive.
//
// Method (Freitag & Plassmann 2000, "Local optimization-based simplicial mesh
// untangling and improvement", IJNME 49; Knupp 2001, "Hexahedral and
// tetrahedral mesh untangling", Eng. with Computers 17): the signed volume
// of every tet of the star of a free vertex v is an affine function of v's
// position x,
//     V_i(x) = g_i . (x - a_i),   g_i = -(b_i - a_i) x (c_i - a_i) / 6
// where (a_i, b_i, c_i) is the face opposite v, ordered outward
// (conventions.hpp).  untangle maximises min_i V_i(x), a concave piecewise
// linear function, by steepest ascent: the direction is the minimum-norm
// point of the convex hull of the gradients of the (nearly) smallest
// volumes (at most 8), and the exact maximum of the min along that ray is
// found by walking the lower envelope of the lines V_i(x + s d).  Stops when
// the direction vanishes (the max-min point) or after max_steps.
//
// Commit rule (exact, predicates.hpp): a new position is kept only if every
// star tet that was Positive stays Positive under orient3d, and either the
// number of non-positive star tets falls or it stays and the smallest star
// volume rises; otherwise the step is halved up to 12 times, then refused.
// Constrained vertices (TetMesh::vert_constrained) never move; connectivity
// never changes; so no positive tet is ever made non-positive, the
// number of non-positive tets never grows, and region volumes are kept (a
// free vertex's star lies in one region and its signed volume is fixed by
// its link).  This is exactly what check_invariants (invariants.hpp) demands
// of a tangled input.
//
// Passes visit the free vertices of the non-positive tets in ascending id
// order (deterministic, single-threaded) until none is left, a pass moves
// nothing, or `passes` passes.  Vertices of positive tets around a tangle
// are not moved (a limitation: such tangles are reported as NoPosition).
//
// Cost: O(nt) per pass for the exact orientation scan plus, per visited
// vertex, O(max_steps * |star|^2) for the envelope walk.
//
// Precondition: build_topology(m) succeeded (vertex->tet CSR and the
// constrained flags).  Postcondition: topology still valid (only
// coordinates change).
#pragma once
#include <cstdint>
#include <vector>

#include "tetopt/mesh.hpp"
#include "tetopt/status.hpp"

namespace tetopt {

/// Why a non-positive tet is still there after untangle().
enum class UntangleReason {
  AllConstrained,  ///< its four vertices are constrained: no vertex may move
  NoPosition,      ///< no position of its free vertices makes it positive without inverting another tet
};

/// "all four vertices constrained" / "no position found".
const char* to_string(UntangleReason r);

struct UntangleRemaining {
  int32_t tet = -1;  ///< 0-based tet id
  UntangleReason reason = UntangleReason::NoPosition;
};

struct UntangleOptions {
  int passes = 20;     ///< sweeps over the vertices of non-positive tets
  int max_steps = 60;  ///< ascent steps per vertex solve
};

struct UntangleStats {
  int64_t nonpositive_before = 0;  ///< inverted + flat tets on entry (exact)
  int64_t nonpositive_after = 0;   ///< on exit; == remaining.size()
  int64_t moves = 0;               ///< vertex moves committed
  int passes = 0;
  double seconds = 0;
  std::vector<UntangleRemaining> remaining;  ///< ascending tet id
  Status status;  ///< not ok when the topology is missing (nothing moved)
};

/// Moves free vertices of inverted / flat tets to make them positive (see
/// the essay).  Logs one Info summary line and, when tets remain, one Warning
/// naming them (first 20 ids, 1-based) and why.
UntangleStats untangle(TetMesh& m, const LogFn& log = {});
UntangleStats untangle(TetMesh& m, const UntangleOptions& o, const LogFn& log = {});

}  // namespace tetopt
