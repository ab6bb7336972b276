// The face pass's topological step (face_pass.hpp, --objective openfoam):
// faces that vertex moves cannot help are removed by edge removal / flips
// chosen by the face measure, and the promise holds after the pass.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <vector>

#include "tetopt/conventions.hpp"
#include "tetopt/face_pass.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/guard.hpp"
#include "tetopt/invariants.hpp"
#include "tetopt/measures.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/predicates.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/topo.hpp"

using namespace tetopt;

namespace {

double worst_alpha(const TetMesh& m) {
  double w = INFINITY;
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = m.tet(t);
    w = std::min(w, alpha(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3])));
  }
  return w;
}

// Three tets around the edge (a, b), a = point 3, b = point 4, with the
// ring r0 r1 r2 (points 0..2) in the plane z = 0; every vertex is on the
// boundary (constrained), so no vertex move is possible.  The faces
// (a, b, r_i) reach 73.6 degrees of non-orthogonality; the 3-2 flip leaves
// the one face (r0, r1, r2) between two tets, at 10.5 degrees, and raises
// the worst alpha from 0.066 to 0.26 (coordinates found by a random search
// over such configurations).
TetMesh three_around_an_edge() {
  const std::array<std::array<double, 3>, 5> p = {{{1.3113, -0.3434, 0.0},
                                                   {-1.2489, 0.7056, 0.0},
                                                   {-0.3084, -0.0505, 0.0},
                                                   {0.6049, 0.0245, 1.7741},
                                                   {0.0517, -0.1453, -1.3549}}};
  TetMesh m;
  for (const auto& x : p) m.xyz.insert(m.xyz.end(), x.begin(), x.end());
  for (int i = 0; i < 3; ++i) {
    std::array<int32_t, 4> t = {3, 4, i, (i + 1) % 3};
    if (orient3d(m.point(t[0]), m.point(t[1]), m.point(t[2]), m.point(t[3])) == Sign::Negative) std::swap(t[2], t[3]);
    m.tets.insert(m.tets.end(), t.begin(), t.end());
    m.tet_ref.push_back(1);
  }
  m.vert_ref.assign(p.size(), 0);
  EXPECT_TRUE(build_topology(m).ok());
  return m;
}

}  // namespace

// Vertex moves cannot touch a mesh whose vertices are all constrained: the
// pass without topology leaves the largest non-orthogonality where it is;
// with topology an edge removal (3-2) takes it from 73.6 to 10.5 degrees,
// the promise kept (constrained vertices and faces bit for bit, volume, no
// inverted tet) and the worst alpha not lowered.
TEST(FacePass, EdgeRemovalLowersAFaceVertexMovesCannotReach) {
  TetMesh m = three_around_an_edge();
  for (int32_t v = 0; v < m.nv(); ++v) ASSERT_TRUE(m.vert_constrained[v]);
  const double before = max_non_orthogonality(m);
  EXPECT_GT(before, 73.0);
  FacePassOptions o;
  o.alpha_floor = worst_alpha(m);
  {
    TetMesh w = m;
    o.topology = false;
    const FacePassStats st = face_pass(w, o);
    EXPECT_EQ(st.moves, 0);
    EXPECT_EQ(st.edge_removals + st.face_removals, 0);
    EXPECT_DOUBLE_EQ(max_non_orthogonality(w), before);
  }
  o.topology = true;
  {
    // With a floor above the worst alpha the 3-2 flip gives (0.26), the
    // flip's tets (four constrained vertices each) are refused, and the
    // diagnosis says so: no move can help the face either.
    TetMesh w = m;
    FacePassOptions high = o;
    high.alpha_floor = 0.3;
    const FacePassStats st = face_pass(w, high);
    EXPECT_EQ(st.edge_removals + st.face_removals, 0);
    EXPECT_DOUBLE_EQ(st.worst_move_floor, st.worst_after);
    EXPECT_GE(st.worst_lowering_options, 1);
    EXPECT_EQ(st.worst_constrained_refused, st.worst_lowering_options);
  }
  const InvariantSnapshot snap = capture_invariants(m);
  const double alpha0 = worst_alpha(m);
  const FacePassStats st = face_pass(m, o);
  EXPECT_EQ(st.edge_removals, 1);
  EXPECT_EQ(m.nt(), 2);
  EXPECT_DOUBLE_EQ(st.worst_before, before);
  EXPECT_LT(st.worst_after, 11.0);
  EXPECT_DOUBLE_EQ(st.worst_after, max_non_orthogonality(m));
  const Status s = check_invariants(m, snap);
  EXPECT_TRUE(s.ok()) << s.message;
  EXPECT_TRUE(nonpositive_tets(m).empty());
  EXPECT_GE(worst_alpha(m), alpha0);
  EXPECT_DOUBLE_EQ(st.worst_move_floor, st.worst_after);  // (r0, r1, r2) between a and b: all constrained
  EXPECT_EQ(st.worst_lowering_options, 0);
}

// The editor's judged operations commit exactly what the judge takes: a
// refusal leaves the mesh as it was, and the judge sees the cavity (its
// old tets) and the new tets with the vertex across each new face.
TEST(FacePass, JudgedEdgeRemovalCommitsOnlyWhatTheJudgeTakes) {
  TetMesh m = three_around_an_edge();
  const std::vector<int32_t> tets0 = m.tets;
  int le = -1;  // the local edge (a, b) of tet 0
  for (int k = 0; k < 6; ++k) {
    const int32_t x = m.tet(0)[kEdgeVertex[k][0]], y = m.tet(0)[kEdgeVertex[k][1]];
    if ((x == 3 && y == 4) || (x == 4 && y == 3)) le = k;
  }
  ASSERT_GE(le, 0);
  {
    TopoEditor ed(m, TopoOptions{});
    int seen_old = 0, seen_new = 0, boundary = 0;
    const TopoResult r = ed.remove_edge_judged(0, le, [&](const TopoEditor::Planned& p) {
      seen_old = p.n_old;
      seen_new = p.n_new;
      for (int i = 0; i < 4 * p.n_new; ++i) boundary += p.across[static_cast<size_t>(i)] < 0;
      return false;
    });
    EXPECT_EQ(r, TopoResult::NotImproved);
    EXPECT_EQ(seen_old, 3);
    EXPECT_EQ(seen_new, 2);
    EXPECT_EQ(boundary, 6);  // two tets, one shared face: six boundary faces
  }
  EXPECT_EQ(m.tets, tets0);
  {
    TopoEditor ed(m, TopoOptions{});
    EXPECT_EQ(ed.remove_edge_judged(0, le, [](const TopoEditor::Planned&) { return true; }), TopoResult::Applied);
  }
  EXPECT_EQ(m.nt(), 2);
  EXPECT_TRUE(nonpositive_tets(m).empty());
}

// On a jittered two-region box under the guards (every measure's worst
// kept, alpha's included), the pass with topology keeps the promise, never
// raises the largest non-orthogonality, and keeps every per-tet worst.
TEST(FacePass, GuardedPassWithTopologyKeepsThePromise) {
  for (uint64_t seed : {3u, 11u}) {
    SCOPED_TRACE(seed);
    TetMesh m = make_box_mesh({.nx = 6, .ny = 6, .nz = 6, .jitter = 0.45, .seed = seed, .regions = 2});
    ASSERT_TRUE(build_topology(m).ok());
    Guard g;
    Guard::take(m, 1, g);
    g.exempt_none();
    const InvariantSnapshot snap = capture_invariants(m);
    FacePassOptions o;
    o.guard = &g;
    const double before = max_non_orthogonality(m);
    const FacePassStats st = face_pass(m, o);
    EXPECT_DOUBLE_EQ(st.worst_before, before);
    EXPECT_LE(st.worst_after, before);
    EXPECT_DOUBLE_EQ(st.worst_after, max_non_orthogonality(m));
    EXPECT_GT(st.edge_removals + st.face_removals, 0);
    const Status s = check_invariants(m, snap);
    EXPECT_TRUE(s.ok()) << s.message;
    EXPECT_TRUE(validate(m).ok());
    for (int32_t t = 0; t < m.nt(); ++t) {
      const int32_t* v = m.tet(t);
      EXPECT_TRUE(g.admits(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3]))) << t;
    }
  }
}
