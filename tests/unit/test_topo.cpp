// Topological operations (topo.hpp): every test checks the invariants that a
// topology change must keep — constrained triangles and coordinates
// bit-identical, no inverted tet, per-region volume, valid adjacency, same
// vertex set and Euler characteristic.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <random>
#include <set>
#include <vector>

#include "detail/shell_alpha.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/improve.hpp"
#include "tetopt/invariants.hpp"
#include "tetopt/io.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/predicates.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/smooth.hpp"
#include "tetopt/topo.hpp"
#include "needle_box.hpp"

using namespace tetopt;

namespace {

using Tri = std::array<int32_t, 3>;

struct Snapshot {
  std::vector<double> xyz;
  std::vector<Tri> constrained;  // sorted vertex triples
  std::vector<std::pair<int32_t, double>> volumes;
  std::vector<int32_t> verts;
  long euler = 0;
};

Snapshot snap(const TetMesh& m) {
  Snapshot s;
  s.xyz = m.xyz;
  std::set<Tri> c;
  std::set<std::array<int32_t, 2>> edges;
  std::set<Tri> faces;
  std::set<int32_t> verts;
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = m.tet(t);
    for (int f = 0; f < 4; ++f) {
      int32_t k[3];
      face_key(m, t, f, k);
      faces.insert({k[0], k[1], k[2]});
      if (m.face_mask[t] & (1u << f)) c.insert({k[0], k[1], k[2]});
    }
    for (int e = 0; e < 6; ++e) {
      int32_t a = v[kEdgeVertex[e][0]], b = v[kEdgeVertex[e][1]];
      edges.insert({std::min(a, b), std::max(a, b)});
    }
    for (int k = 0; k < 4; ++k) verts.insert(v[k]);
  }
  s.constrained.assign(c.begin(), c.end());
  s.volumes = region_volumes(m);
  s.verts.assign(verts.begin(), verts.end());
  s.euler = static_cast<long>(verts.size()) - static_cast<long>(edges.size()) + static_cast<long>(faces.size()) -
            m.nt();
  return s;
}

void expect_invariants(const Snapshot& before, const TetMesh& m) {
  const Status st = validate(m, ValidateLevel::Full);
  ASSERT_TRUE(st.ok()) << st.message;
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = m.tet(t);
    ASSERT_EQ(orient3d(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3])), Sign::Positive) << t;
  }
  const Snapshot after = snap(m);
  ASSERT_EQ(before.xyz.size(), after.xyz.size());
  EXPECT_EQ(0, std::memcmp(before.xyz.data(), after.xyz.data(), before.xyz.size() * sizeof(double)));
  EXPECT_EQ(before.constrained, after.constrained);
  EXPECT_EQ(before.verts, after.verts);
  EXPECT_EQ(before.euler, after.euler);
  ASSERT_EQ(before.volumes.size(), after.volumes.size());
  for (size_t i = 0; i < before.volumes.size(); ++i) {
    EXPECT_EQ(before.volumes[i].first, after.volumes[i].first);
    EXPECT_NEAR(before.volumes[i].second, after.volumes[i].second, 1e-12 * std::fabs(before.volumes[i].second));
  }
}

// A mesh from points and tets (each tet made positive), topology built.
TetMesh make_mesh(const std::vector<std::array<double, 3>>& pts, const std::vector<std::array<int32_t, 4>>& tets) {
  TetMesh m;
  for (const auto& p : pts) m.xyz.insert(m.xyz.end(), p.begin(), p.end());
  for (auto t : tets) {
    if (orient3d(m.point(t[0]), m.point(t[1]), m.point(t[2]), m.point(t[3])) == Sign::Negative)
      std::swap(t[2], t[3]);
    m.tets.insert(m.tets.end(), t.begin(), t.end());
    m.tet_ref.push_back(1);
  }
  m.vert_ref.assign(pts.size(), 0);
  EXPECT_TRUE(build_topology(m).ok());
  return m;
}

double worst_alpha(const TetMesh& m) {
  double w = 2;
  for (int32_t t = 0; t < m.nt(); ++t) w = std::min(w, tet_alpha(m, t));
  return w;
}

// Shell of n tets around edge a=(0,0,-h) .. b=(0,0,h); ring of radius R,
// slightly non-planar.  Vertex 0 = a, 1 = b, 2.. = ring.
std::vector<std::array<double, 3>> ring_points(int n, double R, double h) {
  std::vector<std::array<double, 3>> p = {{0, 0, -h}, {0, 0, h}};
  for (int i = 0; i < n; ++i) {
    const double th = 2 * M_PI * i / n;
    p.push_back({R * std::cos(th), R * std::sin(th), 0.05 * ((i * 7) % 3)});
  }
  return p;
}
TetMesh make_shell(int n, double R, double h) {
  std::vector<std::array<int32_t, 4>> t;
  for (int i = 0; i < n; ++i) t.push_back({0, 1, 2 + i, 2 + (i + 1) % n});
  return make_mesh(ring_points(n, R, h), t);
}
// The ring of ring_points(n, 1, 0.6) triangulated as a fan from vertex 2 and
// sandwiched between a and b: 2 (n - 2) tets, the reverse of a shell.
TetMesh make_fan_sandwich(int n) {
  std::vector<std::array<int32_t, 4>> tets;
  for (int k = 1; k + 1 < n; ++k) {
    tets.push_back({2, 2 + k, 2 + k + 1, 1});
    tets.push_back({2, 2 + k + 1, 2 + k, 0});
  }
  return make_mesh(ring_points(n, 1.0, 0.6), tets);
}

// Finds tet and local edge of edge (a, b).
bool find_edge(const TetMesh& m, int32_t a, int32_t b, int32_t& t, int& le) {
  for (t = 0; t < m.nt(); ++t)
    for (le = 0; le < 6; ++le) {
      const int32_t x = m.tets[4 * t + kEdgeVertex[le][0]], y = m.tets[4 * t + kEdgeVertex[le][1]];
      if ((x == a && y == b) || (x == b && y == a)) return true;
    }
  return false;
}

double alpha_pts(const std::vector<std::array<double, 3>>& p, int i, int j, int k, int l) {
  return alpha(p[i].data(), p[j].data(), p[k].data(), p[l].data());
}

// Brute force over all triangulations of the ring polygon (independent of
// the library's DP): best worst alpha of the 2n-4 tets.
double brute_force_best(const std::vector<std::array<double, 3>>& p, int n) {
  std::function<std::vector<double>(int, int)> rec = [&](int i, int j) -> std::vector<double> {
    if (j - i < 2) return {2.0};
    std::vector<double> out;
    for (int k = i + 1; k < j; ++k) {
      const double tq = std::min(alpha_pts(p, 2 + i, 2 + k, 2 + j, 1), alpha_pts(p, 2 + i, 2 + j, 2 + k, 0));
      for (double l : rec(i, k))
        for (double r : rec(k, j)) out.push_back(std::min({tq, l, r}));
    }
    return out;
  };
  double best = -2;
  for (double v : rec(0, n - 1)) best = std::max(best, v);
  return best;
}

bool has_vertex(const TetMesh& m, int32_t t, int32_t v) {
  for (int k = 0; k < 4; ++k)
    if (m.tets[4 * t + k] == v) return true;
  return false;
}

}  // namespace

TEST(Topo, ThreeTwoRemovesInteriorEdge) {
  TetMesh m = make_shell(3, 0.5, 1.0);
  const Snapshot s = snap(m);
  const double before = worst_alpha(m);
  int32_t t;
  int le;
  ASSERT_TRUE(find_edge(m, 0, 1, t, le));
  EXPECT_EQ(m.tet_kind[t], 4);
  EXPECT_EQ(flip_32(m, t, le), TopoResult::Applied);
  ASSERT_EQ(m.nt(), 2);
  expect_invariants(s, m);
  EXPECT_GT(worst_alpha(m), before);
  EXPECT_FALSE(find_edge(m, 0, 1, t, le));
}

TEST(Topo, ThreeTwoRefusedWhenWorse) {
  TetMesh m = make_shell(3, 2.0, 0.3);  // the 3 tets are better than the 2
  const auto tets = m.tets;
  int32_t t;
  int le;
  ASSERT_TRUE(find_edge(m, 0, 1, t, le));
  EXPECT_EQ(flip_32(m, t, le), TopoResult::NotImproved);
  EXPECT_EQ(m.tets, tets);
  // Boundary edges are locked, and 2-2 is always refused.
  ASSERT_TRUE(find_edge(m, 0, 2, t, le));
  EXPECT_EQ(remove_edge(m, t, le), TopoResult::BoundaryLocked);
  TopoEditor ed(m, {});
  EXPECT_EQ(ed.flip_22(t, le), TopoResult::BoundaryLocked);
  ASSERT_TRUE(find_edge(m, 0, 1, t, le));
  EXPECT_EQ(ed.flip_22(t, le), TopoResult::NotApplicable);
}

TEST(Topo, NeverCreatesAListedTriangle) {
  // The 3-2 would create face (r0, r1, r2); listing it as a triangle (not a
  // face of the mesh now) must lock the flip, which otherwise applies.
  TetMesh m = make_shell(3, 0.5, 1.0);
  m.tris = {2, 3, 4};
  m.tri_ref = {5};
  ASSERT_TRUE(build_topology(m).ok());
  int32_t t;
  int le;
  ASSERT_TRUE(find_edge(m, 0, 1, t, le));
  EXPECT_EQ(flip_32(m, t, le), TopoResult::BoundaryLocked);
  EXPECT_EQ(m.nt(), 3);
  m.tris = {2, 3, 0};  // a listed triangle that is a face: kept
  ASSERT_TRUE(build_topology(m).ok());
  const Snapshot s = snap(m);
  ASSERT_TRUE(find_edge(m, 0, 1, t, le));
  EXPECT_EQ(flip_32(m, t, le), TopoResult::Applied);
  expect_invariants(s, m);
}

TEST(Topo, TwoThreeAddsEdge) {
  // Two flat tets on a wide triangle; the 2-3 gives three better tets.
  auto p = ring_points(3, 2.0, 0.3);
  TetMesh m = make_mesh(p, {{0, 2, 3, 4}, {1, 2, 3, 4}});
  const Snapshot s = snap(m);
  const double before = worst_alpha(m);
  int32_t t = 0;
  int lf = 0;
  for (; lf < 4; ++lf)
    if (m.adj[4 * t + lf] >= 0) break;
  ASSERT_LT(lf, 4);
  EXPECT_EQ(flip_23(m, t, lf), TopoResult::Applied);
  ASSERT_EQ(m.nt(), 3);
  expect_invariants(s, m);
  EXPECT_GT(worst_alpha(m), before);
  for (int32_t u = 0; u < 3; ++u) EXPECT_TRUE(has_vertex(m, u, 0) && has_vertex(m, u, 1));
  // Across a boundary face: locked.
  TetMesh m2 = make_mesh(p, {{0, 2, 3, 4}, {1, 2, 3, 4}});
  int bf = 0;
  while (m2.adj[bf] >= 0) ++bf;
  EXPECT_EQ(flip_23(m2, 0, bf), TopoResult::BoundaryLocked);
}

TEST(Topo, TwoThreeRefusedWhenWorse) {
  auto p = ring_points(3, 0.5, 1.0);
  TetMesh m = make_mesh(p, {{0, 2, 3, 4}, {1, 2, 3, 4}});
  const auto tets = m.tets;
  int lf = 0;
  while (m.adj[lf] < 0) ++lf;
  EXPECT_EQ(flip_23(m, 0, lf), TopoResult::NotImproved);
  EXPECT_EQ(m.tets, tets);
}

TEST(Topo, EdgeRemovalMatchesBruteForceTriangulation) {
  int applied = 0;
  for (int n = 4; n <= 7; ++n)
    for (double h : {1.0, 1.5}) {
      SCOPED_TRACE("n=" + std::to_string(n) + " h=" + std::to_string(h));
      TetMesh m = make_shell(n, 0.5, h);
      const Snapshot s = snap(m);
      const double before = worst_alpha(m);
      const double best = brute_force_best(ring_points(n, 0.5, h), n);
      int32_t t;
      int le;
      ASSERT_TRUE(find_edge(m, 0, 1, t, le));
      TopoOptions o;
      const TopoResult r = remove_edge(m, t, le, o);
      if (best > before + o.margin) {
        ASSERT_EQ(r, TopoResult::Applied);
        ++applied;
        EXPECT_EQ(m.nt(), 2 * n - 4);
        expect_invariants(s, m);
        EXPECT_NEAR(worst_alpha(m), best, 1e-12);
        EXPECT_FALSE(find_edge(m, 0, 1, t, le));
      } else {
        EXPECT_EQ(r, TopoResult::NotImproved);
        EXPECT_EQ(m.nt(), n);
      }
    }
  EXPECT_GE(applied, 5);
}

TEST(Topo, EdgeRemovalLimitsAndLocks) {
  TetMesh m = make_shell(7, 0.5, 1.5);
  int32_t t;
  int le;
  ASSERT_TRUE(find_edge(m, 0, 1, t, le));
  TopoOptions o;
  o.max_shell = 6;
  EXPECT_EQ(remove_edge(m, t, le, o), TopoResult::ShellTooLarge);
  EXPECT_EQ(m.nt(), 7);
  // Listed edge: never removed.
  TetMesh m2 = make_shell(5, 0.5, 1.0);
  m2.edges = {0, 1};
  m2.edge_ref = {3};
  ASSERT_TRUE(build_topology(m2).ok());
  ASSERT_TRUE(find_edge(m2, 0, 1, t, le));
  EXPECT_EQ(remove_edge(m2, t, le), TopoResult::BoundaryLocked);
  // Two regions in the shell: the faces between them are interfaces.
  TetMesh m3 = make_shell(5, 0.5, 1.0);
  m3.tet_ref[2] = 2;
  ASSERT_TRUE(build_topology(m3).ok());
  ASSERT_TRUE(find_edge(m3, 0, 1, t, le));
  EXPECT_EQ(remove_edge(m3, t, le), TopoResult::RegionMismatch);
  EXPECT_EQ(m3.nt(), 5);
  // Gmsh entities count as regions too.
  TetMesh m5 = make_shell(5, 0.5, 1.0);
  m5.tet_entity = {1, 1, 1, 2, 1};
  ASSERT_TRUE(build_topology(m5).ok());
  ASSERT_TRUE(find_edge(m5, 0, 1, t, le));
  EXPECT_EQ(remove_edge(m5, t, le), TopoResult::RegionMismatch);
  // flip_32 / flip_44 insist on their shell size.
  TetMesh m4 = make_shell(5, 0.5, 1.0);
  ASSERT_TRUE(find_edge(m4, 0, 1, t, le));
  EXPECT_EQ(flip_32(m4, t, le), TopoResult::NotApplicable);
}

TEST(Topo, FlipFourFour) {
  TetMesh m = make_shell(4, 0.5, 1.0);
  const Snapshot s = snap(m);
  int32_t t;
  int le;
  ASSERT_TRUE(find_edge(m, 0, 1, t, le));
  TopoEditor ed(m, {});
  EXPECT_EQ(ed.flip_44(t, le), TopoResult::Applied);
  EXPECT_EQ(ed.stats().flip44, 1);
  ed.finish();
  EXPECT_EQ(m.nt(), 4);
  expect_invariants(s, m);
}

TEST(Topo, MultiFaceRemovalInvertsEdgeRemoval) {
  // Fan triangulation of a 5-ring sandwiched between a and b; the 5 tets
  // around ab are much better (see EdgeRemoval tests for the reverse case).
  const int n = 5;
  const auto p = ring_points(n, 1.0, 0.6);
  TetMesh m = make_fan_sandwich(n);
  const Snapshot s = snap(m);
  double shell = 2;
  for (int i = 0; i < n; ++i) shell = std::min(shell, alpha_pts(p, 0, 1, 2 + i, 2 + (i + 1) % n));
  // Start at tet 1 (contains a = vertex 0), face opposite a.
  int lf = 0;
  while (m.tets[4 * 1 + lf] != 0) ++lf;
  TopoEditor ed(m, {});
  EXPECT_EQ(ed.remove_multi_face(1, lf), TopoResult::Applied);
  EXPECT_EQ(ed.stats().multi_face_removals, 1);
  ed.finish();
  ASSERT_EQ(m.nt(), n);
  expect_invariants(s, m);
  for (int32_t t = 0; t < n; ++t) EXPECT_TRUE(has_vertex(m, t, 0) && has_vertex(m, t, 1));
  EXPECT_NEAR(worst_alpha(m), shell, 1e-12);
}

TEST(Topo, MultiFaceRemovalKeepsAListedEdge) {
  // The same sandwich with fan diagonal (2, 4) listed as an edge: removing
  // all three sandwich faces would delete it (it was deleted so on the
  // command line, with meshcheck none the wiser); the removal may take only
  // faces on one side of it, and the edge stays an edge of the mesh.
  const int n = 5;
  TetMesh m = make_fan_sandwich(n);
  TetMesh unlisted = m;
  m.edges = {4, 2, 0, 1};  // (0, 1) is no edge of the mesh yet: nothing to keep
  m.edge_ref = {9, 8};
  ASSERT_TRUE(build_topology(m).ok());
  const Snapshot s = snap(m);
  const InvariantSnapshot proof = capture_invariants(m);
  EXPECT_EQ(proof.edges_in_mesh, std::vector<int32_t>{0});
  int lf = 0;
  while (m.tets[4 * 1 + lf] != 0) ++lf;
  {
    TopoEditor ed(m, {});
    ed.remove_multi_face(1, lf);
    ed.finish();
  }
  expect_invariants(s, m);
  bool found = false;
  for (int32_t t = 0; t < m.nt() && !found; ++t) found = has_vertex(m, t, 2) && has_vertex(m, t, 4);
  EXPECT_TRUE(found);
  EXPECT_GT(m.nt(), n);  // not the 5 tets around (0, 1) of the unlisted case
  EXPECT_TRUE(check_invariants(m, proof).ok()) << check_invariants(m, proof).message;
  // The library's proof catches the loss: the same removal without the
  // list, then the list put back.
  ASSERT_TRUE(build_topology(unlisted).ok());
  {
    TopoEditor ed(unlisted, {});
    ASSERT_EQ(ed.remove_multi_face(1, lf), TopoResult::Applied);
    ed.finish();
  }
  unlisted.edges = m.edges;
  unlisted.edge_ref = m.edge_ref;
  classify(unlisted);
  const Status st = check_invariants(unlisted, proof);
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.message.find("listed edge 1 (vertices 5 3) is no longer an edge"), std::string::npos) << st.message;
}

TEST(Topo, EditorKeepsAdjacencyAndMasksIncrementally) {
  BoxMeshOptions bo;
  bo.nx = bo.ny = bo.nz = 4;
  bo.jitter = 0.4;
  bo.seed = 7;
  bo.regions = 2;
  TetMesh m = make_box_mesh(bo);
  ASSERT_TRUE(build_topology(m).ok());
  TopoOptions o;
  o.quality_threshold = 0.5;
  TopoEditor ed(m, o);
  int applied = 0;
  for (int32_t t = 0; t < m.nt(); ++t)
    if (ed.alive(t) && ed.cached_alpha(t) < 0.5) applied += ed.improve_tet(t, true) == TopoResult::Applied;
  EXPECT_GT(applied, 0);
  // Before finish(): every live tet's adjacency is symmetric and its mask is
  // what classify() would say.
  std::set<Tri> listed;
  for (int32_t i = 0; i < m.ntri(); ++i) {
    Tri k{m.tris[3 * i], m.tris[3 * i + 1], m.tris[3 * i + 2]};
    std::sort(k.begin(), k.end());
    listed.insert(k);
  }
  for (int32_t t = 0; t < m.nt(); ++t) {
    if (!ed.alive(t)) continue;
    int kind = 0;
    for (int k = 0; k < 4; ++k) kind += m.vert_constrained[m.tets[4 * t + k]];
    EXPECT_EQ(m.tet_kind[t], kind);
    EXPECT_NEAR(ed.cached_alpha(t), tet_alpha(m, t), 1e-15);
    for (int f = 0; f < 4; ++f) {
      const int32_t nb = m.adj[4 * t + f];
      if (nb >= 0) {
        ASSERT_TRUE(ed.alive(nb / 4));
        ASSERT_EQ(m.adj[nb], 4 * t + f);
      }
      int32_t k[3];
      face_key(m, t, f, k);
      const bool c = nb < 0 || m.tet_ref[nb / 4] != m.tet_ref[t] || listed.count({k[0], k[1], k[2]});
      EXPECT_EQ(((m.face_mask[t] >> f) & 1u) != 0, c) << t << " " << f;
    }
  }
}

TEST(Topo, FlipPassOnJitteredBoxKeepsInvariants) {
  for (int regions : {1, 2}) {
    SCOPED_TRACE(regions);
    BoxMeshOptions bo;
    bo.nx = 6; bo.ny = 5; bo.nz = 4;
    bo.jitter = 0.45;
    bo.seed = 11;
    bo.regions = regions;
    TetMesh m = make_box_mesh(bo);
    ASSERT_TRUE(build_topology(m).ok());
    const Snapshot s = snap(m);
    TopoOptions o;
    o.quality_threshold = 0.4;
    const TopoStats st = flip_pass(m, o);
    ASSERT_TRUE(st.status.ok());
    EXPECT_GT(st.applied(), 0);
    expect_invariants(s, m);
    // Every commit raises the worst alpha of its cavity, so the global worst
    // cannot drop.
    EXPECT_GE(st.alpha_worst_after, st.alpha_worst_before);
    EXPECT_EQ(st.tets_after, m.nt());
    EXPECT_NEAR(st.alpha_worst_after, worst_alpha(m), 0);
  }
}

TEST(Topo, FlipPassIsDeterministic) {
  BoxMeshOptions bo;
  bo.nx = bo.ny = bo.nz = 5;
  bo.jitter = 0.45;
  bo.seed = 3;
  TetMesh a = make_box_mesh(bo);
  ASSERT_TRUE(build_topology(a).ok());
  TetMesh b = a;
  flip_pass(a, {});
  flip_pass(b, {});
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_EQ(a.adj, b.adj);
}

TEST(Topo, AllBoundaryTetsOnBox) {
  // Two-region box: kind-4 tets along the surface and the interface.
  for (bool must : {true, false}) {
    SCOPED_TRACE(must);
    BoxMeshOptions bo;
    bo.nx = 4; bo.ny = 4; bo.nz = 3;
    bo.jitter = 0.3;
    bo.regions = 2;
    TetMesh m = make_box_mesh(bo);
    ASSERT_TRUE(build_topology(m).ok());
    const Snapshot s = snap(m);
    TopoOptions o;
    o.must_improve = must;
    o.worsen_bound = 0.2;
    o.quality_threshold = 2;  // every kind-4 tet
    const TopoStats st = remove_all_boundary_tets(m, o);
    ASSERT_TRUE(st.status.ok());
    EXPECT_GT(st.kind4_before, 0);
    expect_invariants(s, m);
    if (must) {
      EXPECT_GE(st.alpha_worst_after, st.alpha_worst_before);
    } else {
      EXPECT_GT(st.all_boundary_removed, 0);
      EXPECT_LT(st.kind4_after, st.kind4_before);
      EXPECT_GE(st.alpha_worst_after, st.alpha_worst_before - o.worsen_bound);
    }
  }
}

TEST(Topo, AllBoundaryShellOfThreeIsRemoved) {
  // Every tet of the shell is kind 4 (all vertices on the boundary).
  TetMesh m = make_shell(3, 0.5, 1.0);
  const Snapshot s = snap(m);
  const TopoStats st = remove_all_boundary_tets(m, {});
  EXPECT_EQ(st.kind4_before, 3);
  EXPECT_EQ(st.kind4_after, 2);
  EXPECT_EQ(st.flip32, 1);
  expect_invariants(s, m);
}

TEST(Topo, HingeRawRealMesh) {
  const std::string path = std::string(TETOPT_SOURCE_DIR) + "/../shared/meshes/hinge_raw/hinge_raw.mesh";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no " << path;
  TetMesh m;
  const Status rs = read_mesh(path, m);
  if (!rs.ok()) GTEST_SKIP() << "reader not available: " << rs.message;
  ASSERT_TRUE(build_topology(m).ok());
  const Snapshot s = snap(m);
  for (bool must : {true, false}) {
    TetMesh w = m;
    TopoOptions o;
    o.must_improve = must;
    o.worsen_bound = 0.05;
    const TopoStats a = remove_all_boundary_tets(w, o);
    const TopoStats b = flip_pass(w, o);
    ASSERT_TRUE(a.status.ok() && b.status.ok());
    expect_invariants(s, w);
    RecordProperty(must ? "strict" : "may_worsen",
                   "alpha " + std::to_string(a.alpha_worst_before) + " -> " + std::to_string(b.alpha_worst_after) +
                       ", kind4 " + std::to_string(a.kind4_before) + " -> " + std::to_string(b.kind4_after));
    if (must) { EXPECT_GT(b.alpha_worst_after, a.alpha_worst_before); }
  }
}

TEST(Topo, FinishKeepsClassificationWithoutReclassifying) {
  // finish() no longer re-runs classify(): the masks and kinds it compacts
  // must equal what classify() computes from scratch (two regions, so
  // interfaces are constrained; listed triangles from the generator).
  for (int regions : {1, 2}) {
    SCOPED_TRACE(regions);
    BoxMeshOptions bo;
    bo.nx = 5; bo.ny = 4; bo.nz = 4;
    bo.jitter = 0.45;
    bo.seed = 5;
    bo.regions = regions;
    TetMesh m = make_box_mesh(bo);
    ASSERT_TRUE(build_topology(m).ok());
    const Snapshot s = snap(m);
    TopoOptions o;
    o.quality_threshold = 0.5;
    const TopoStats st = flip_pass(m, o);
    ASSERT_GT(st.applied(), 0);
    const std::vector<uint8_t> mask = m.face_mask, kind = m.tet_kind, vc = m.vert_constrained;
    const std::vector<int32_t> off = m.vt_offsets, vt = m.vt_tets;
    classify(m);
    EXPECT_EQ(mask, m.face_mask);
    EXPECT_EQ(kind, m.tet_kind);
    EXPECT_EQ(vc, m.vert_constrained);
    build_vertex_tets(m);
    EXPECT_EQ(off, m.vt_offsets);
    EXPECT_EQ(vt, m.vt_tets);
    expect_invariants(s, m);
  }
}

TEST(Topo, PassesWithoutStarRebuildLeaveStarsEmptyAndTheirReadersBuildThem) {
  // rebuild_stars = false: a pass that changed the mesh clears the
  // vertex->tet CSR; smoothing rebuilds it on entry, so the flips + smoothing
  // sequence gives the same mesh as with a rebuild after every pass; improve()
  // returns the stars built.
  for (int regions : {1, 2}) {
    SCOPED_TRACE(regions);
    const BoxMeshOptions bo{.nx = 5, .ny = 5, .nz = 4, .jitter = 0.45, .seed = 7, .regions = regions};
    TetMesh a = make_box_mesh(bo);
    ASSERT_TRUE(build_topology(a).ok());
    TetMesh b = a;
    // The library's proof: constrained vertices and faces, region volumes,
    // exact orientation (smoothing moves the free vertices).
    const InvariantSnapshot inv = capture_invariants(a);
    for (TetMesh* m : {&a, &b}) {
      TopoOptions o;
      o.quality_threshold = 0.5;
      o.rebuild_stars = m == &b;
      const TopoStats st = flip_pass(*m, o);
      ASSERT_TRUE(st.status.ok());
      ASSERT_GT(st.applied(), 0);
      if (m == &a) {
        EXPECT_TRUE(a.vt_offsets.empty());
        EXPECT_TRUE(a.vt_tets.empty());
      }
      ASSERT_TRUE(remove_all_boundary_tets(*m, o).status.ok());
      SmoothOptions so;
      so.threshold = 0.5;
      EXPECT_GT(smooth_pass(*m, so).moves_applied, 0);
    }
    EXPECT_EQ(a.tets, b.tets);
    EXPECT_EQ(a.xyz, b.xyz);
    EXPECT_EQ(a.vt_offsets, b.vt_offsets);
    EXPECT_EQ(a.vt_tets, b.vt_tets);
    TetMesh fresh = a;
    build_vertex_tets(fresh);
    EXPECT_EQ(a.vt_offsets, fresh.vt_offsets);
    EXPECT_EQ(a.vt_tets, fresh.vt_tets);
    EXPECT_TRUE(check_invariants(a, inv).ok());

    TetMesh c = make_box_mesh(bo);
    ASSERT_TRUE(build_topology(c).ok());
    ImproveOptions io;
    ImproveReport rep;
    ASSERT_TRUE(improve(c, io, rep).ok());
    EXPECT_GT(rep.flip23 + rep.flip32 + rep.flip44 + rep.edge_removals + rep.multi_face_removals, 0);
    TetMesh c2 = c;
    build_vertex_tets(c2);
    ASSERT_EQ(c.vt_offsets.size(), static_cast<size_t>(c.nv()) + 1);
    EXPECT_EQ(c.vt_offsets, c2.vt_offsets);
    EXPECT_EQ(c.vt_tets, c2.vt_tets);
  }
}

TEST(Topo, LaterPassesVisitOnlyChangedNeighbourhoods) {
  // Pass 2 visits only poor tets next to a pass-1 change, so it visits fewer
  // tets than pass 1 did, yet a pass that applies nothing still ends the loop
  // with the same result as visiting everything would.
  BoxMeshOptions bo;
  bo.nx = bo.ny = bo.nz = 6;
  bo.jitter = 0.45;
  bo.seed = 9;
  TetMesh m = make_box_mesh(bo);
  ASSERT_TRUE(build_topology(m).ok());
  std::vector<int64_t> visited;
  TopoOptions o;
  o.quality_threshold = 0.4;
  o.passes = 10;
  const TopoStats st = flip_pass(m, o, [&](LogLevel, const std::string& s) {
    const auto k = s.find(": ");
    if (k != std::string::npos) visited.push_back(std::stoll(s.substr(k + 2)));
  });
  ASSERT_GE(visited.size(), 2u);
  EXPECT_LT(visited[1], visited[0]);
  // A fresh pass over every poor tet of the result finds nothing more.
  TopoOptions o1 = o;
  o1.passes = 1;
  const TopoStats again = flip_pass(m, o1);
  EXPECT_EQ(again.applied(), 0) << st.applied();
}

namespace {
double min_dihedral(const TetMesh& m) {
  double lo = 180;
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = m.tet(t);
    double d[6];
    dihedral_angles(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3]), d);
    lo = std::min(lo, *std::min_element(d, d + 6));
  }
  return lo;
}
}  // namespace

TEST(Topo, DihedralPassRaisesAnglesWithoutLoweringWorstAlpha) {
  for (int regions : {1, 2}) {
    SCOPED_TRACE(regions);
    BoxMeshOptions bo;
    bo.nx = 5; bo.ny = 5; bo.nz = 4;
    bo.jitter = 0.45;
    bo.seed = 13;
    bo.regions = regions;
    TetMesh m = make_box_mesh(bo);
    ASSERT_TRUE(build_topology(m).ok());
    // Constrained coordinates must stay bit-identical; free ones may move.
    std::vector<double> fixed;
    for (int32_t v = 0; v < m.nv(); ++v)
      if (m.vert_constrained[v]) fixed.insert(fixed.end(), m.point(v), m.point(v) + 3);
    Snapshot s = snap(m);
    const double a0 = worst_alpha(m), d0 = min_dihedral(m);
    TopoOptions o;
    o.quality_threshold = 1.0;
    o.passes = 4;
    const TopoStats st = dihedral_pass(m, o);
    ASSERT_TRUE(st.status.ok());
    EXPECT_GT(st.applied() + st.vertex_moves, 0);
    EXPECT_GE(worst_alpha(m), a0);
    EXPECT_GT(min_dihedral(m), d0);
    EXPECT_GE(st.alpha_worst_after, st.alpha_worst_before);
    std::vector<double> fixed_after;
    for (int32_t v = 0; v < m.nv(); ++v)
      if (m.vert_constrained[v]) fixed_after.insert(fixed_after.end(), m.point(v), m.point(v) + 3);
    ASSERT_EQ(fixed.size(), fixed_after.size());
    EXPECT_EQ(0, std::memcmp(fixed.data(), fixed_after.data(), fixed.size() * sizeof(double)));
    s.xyz = m.xyz;  // free vertices moved on purpose; the rest is checked as usual
    expect_invariants(s, m);
  }
}

// The dihedral measure defers the tets whose alpha proves them good (their
// measure is computed on first use and cached); improve_tets plans such
// passes in parallel too, computing a deferred measure without storing it
// while the threads plan.  The pass must end bit for bit where the serial
// one ends.
TEST(Topo, DihedralPassPlansInParallelWithTheSerialResult) {
  if (TopoEditor::plan_threads(2) < 2) GTEST_SKIP() << "no second thread (one hardware thread, or no oneTBB)";
  int64_t planned = 0;
  for (uint64_t seed : {13u, 14u, 15u}) {
    SCOPED_TRACE(seed);
    BoxMeshOptions bo;
    bo.nx = 8; bo.ny = 8; bo.nz = 6;
    bo.jitter = 0.45;
    bo.seed = seed;
    TetMesh m0 = make_box_mesh(bo);
    ASSERT_TRUE(build_topology(m0).ok());
    const Snapshot s = snap(m0);
    TetMesh serial = m0, ahead = m0;
    TopoOptions o;
    o.quality_threshold = 0.5;
    o.passes = 2;
    o.threads = 1;
    const TopoStats s1 = dihedral_pass(serial, o);
    o.threads = 2;
    const TopoStats s2 = dihedral_pass(ahead, o);
    ASSERT_TRUE(s1.status.ok() && s2.status.ok());
    EXPECT_EQ(s1.planned_ahead, 0);
    planned += s2.planned_ahead;
    EXPECT_GT(s1.applied(), 0);
    EXPECT_EQ(s1.applied(), s2.applied());
    EXPECT_EQ(s1.vertex_moves, s2.vertex_moves);
    EXPECT_EQ(serial.tets, ahead.tets);
    ASSERT_EQ(serial.xyz.size(), ahead.xyz.size());
    EXPECT_EQ(0, std::memcmp(serial.xyz.data(), ahead.xyz.data(), serial.xyz.size() * sizeof(double)));
    Snapshot want = s;
    want.xyz = ahead.xyz;  // free vertices move on purpose; constrained ones are compared below
    expect_invariants(want, ahead);
    for (int32_t v = 0; v < m0.nv(); ++v) {
      if (!m0.vert_constrained[v]) continue;
      for (int k = 0; k < 3; ++k) ASSERT_EQ(ahead.point(v)[k], m0.point(v)[k]) << v;
    }
  }
  RecordProperty("planned_ahead", static_cast<int>(planned));
  EXPECT_GT(planned, 0) << "no window was planned in parallel";
}

namespace {
// tests/data/medit/sliver_pair.mesh: 68 tets cut from the demo impeller,
// every vertex required; one all-boundary sliver (alpha 0.0342) that no
// single operation improves.
TetMesh sliver_pair_mesh() {
  TetMesh m;
  const Status s = read_mesh(std::string(TETOPT_SOURCE_DIR) + "/tests/data/medit/sliver_pair.mesh", m);
  EXPECT_TRUE(s.ok()) << s.message;
  EXPECT_TRUE(build_topology(m).ok());
  return m;
}
int32_t worst_tet(const TetMesh& m) {
  int32_t w = 0;
  for (int32_t t = 1; t < m.nt(); ++t)
    if (tet_alpha(m, t) < tet_alpha(m, w)) w = t;
  return w;
}
}  // namespace

TEST(Topo, PairOfOperationsEscapesTheSingleFlipOptimum) {
  TetMesh m = sliver_pair_mesh();
  for (int32_t t = 0; t < m.nt(); ++t) ASSERT_EQ(m.tet_kind[t], 4);
  const Snapshot s = snap(m);
  const int32_t t = worst_tet(m);
  const double a0 = tet_alpha(m, t);
  ASSERT_LT(a0, 0.05);
  const std::vector<int32_t> tets0 = m.tets, adj0 = m.adj;
  {
    TopoEditor ed(m, {});
    // No single operation on the sliver raises the worst alpha of its cavity...
    EXPECT_NE(ed.improve_tet(t, true), TopoResult::Applied);
    EXPECT_EQ(m.tets, tets0);
    // ...a pair does.
    ASSERT_EQ(ed.improve_tet_pair(t), TopoResult::Applied);
    EXPECT_EQ(ed.stats().pairs, 1);
    EXPECT_EQ(ed.stats().applied(), 2);
    ed.finish();
  }
  expect_invariants(s, m);
  EXPECT_GT(worst_alpha(m), 0.3);
  // A pass of single operations on the poor tets cannot do this (the
  // other tets are above 0.55; flips among them happen to open the way).
  TetMesh single = sliver_pair_mesh();
  TopoOptions o;
  o.quality_threshold = 0.3;
  EXPECT_EQ(flip_pass(single, o).applied(), 0);
  EXPECT_EQ(worst_alpha(single), a0);
  // The pair pass with the same threshold does it.
  const TopoStats st = pair_flip_pass(single, o, 1.0, -1);
  EXPECT_EQ(st.pairs, 1);
  EXPECT_GT(worst_alpha(single), 0.3);
}

TEST(Topo, PairTrialsThatFailLeaveTheMeshAsItWas) {
  // On a jittered box many tets have no improving pair: each call that
  // refuses must leave every live tet, link, mask and cached alpha as it was.
  BoxMeshOptions bo;
  bo.nx = bo.ny = bo.nz = 4;
  bo.jitter = 0.45;
  bo.seed = 5;
  bo.regions = 2;
  TetMesh m = make_box_mesh(bo);
  ASSERT_TRUE(build_topology(m).ok());
  const Snapshot s = snap(m);
  TopoOptions o;
  TopoEditor ed(m, o);
  int refused = 0, applied = 0;
  for (int32_t t = 0; t < m.nt(); ++t) {
    if (!ed.alive(t)) continue;
    const std::vector<int32_t> tets0 = m.tets, adj0 = m.adj;
    const std::vector<uint8_t> mask0 = m.face_mask, kind0 = m.tet_kind;
    std::vector<double> a0(m.nt());
    for (int32_t u = 0; u < m.nt(); ++u) a0[u] = ed.alive(u) ? ed.cached_alpha(u) : 0;
    const int64_t before = ed.stats().applied();
    if (ed.improve_tet_pair(t) == TopoResult::Applied) {
      ++applied;
      EXPECT_GT(ed.stats().applied(), before);
      continue;
    }
    ++refused;
    EXPECT_EQ(ed.stats().applied(), before);
    // Trials may append slots, which stay tombstones.
    ASSERT_GE(m.nt(), static_cast<int32_t>(tets0.size() / 4));
    for (int32_t u = 0; u < m.nt(); ++u) {
      if (u >= static_cast<int32_t>(tets0.size() / 4)) {
        EXPECT_FALSE(ed.alive(u));
        continue;
      }
      ASSERT_EQ(ed.alive(u), tets0[4 * u] >= 0) << u;
      if (!ed.alive(u)) continue;
      for (int k = 0; k < 4; ++k) {
        ASSERT_EQ(m.tets[4 * u + k], tets0[4 * u + k]) << u;
        ASSERT_EQ(m.adj[4 * u + k], adj0[4 * u + k]) << u;
      }
      ASSERT_EQ(m.face_mask[u], mask0[u]);
      ASSERT_EQ(m.tet_kind[u], kind0[u]);
      ASSERT_EQ(ed.cached_alpha(u), a0[u]);
    }
  }
  EXPECT_GT(refused, 0);
  EXPECT_GT(applied, 0);
  ed.finish();
  expect_invariants(s, m);
}

TEST(Topo, PairPassKeepsInvariantsAndIsDeterministic) {
  for (int regions : {1, 2}) {
    SCOPED_TRACE(regions);
    BoxMeshOptions bo;
    bo.nx = 6; bo.ny = 5; bo.nz = 4;
    bo.jitter = 0.45;
    bo.seed = 17;
    bo.regions = regions;
    TetMesh m = make_box_mesh(bo);
    ASSERT_TRUE(build_topology(m).ok());
    TopoOptions o;
    o.quality_threshold = 0.4;
    flip_pass(m, o);  // the pair pass is meant for what single flips leave
    const Snapshot s = snap(m);
    TetMesh b = m;
    ASSERT_TRUE(build_topology(b).ok());
    const TopoStats st = pair_flip_pass(m, o, 1.0, -1);
    ASSERT_TRUE(st.status.ok());
    expect_invariants(s, m);
    EXPECT_GE(st.alpha_worst_after, st.alpha_worst_before);
    EXPECT_NEAR(st.alpha_worst_after, worst_alpha(m), 0);
    EXPECT_GT(st.pairs, 0);
    EXPECT_GE(st.applied(), 2 * st.pairs);
    o.threads = 3;
    pair_flip_pass(b, o, 1.0, -1);
    EXPECT_EQ(m.tets, b.tets);
    EXPECT_EQ(m.adj, b.adj);
  }
}

TEST(Topo, DihedralMeasureDeferralIsALowerBound) {
  // The editor defers the dihedral measure of tets whose bound (from the
  // face-normal cosines) reaches the threshold; below() must still answer as
  // the measure itself would, and cached_alpha() must give the measure,
  // computed here from dihedral_angles independently.
  BoxMeshOptions bo;
  bo.nx = bo.ny = bo.nz = 6;
  bo.jitter = 0.45;
  bo.seed = 23;
  TetMesh m = make_box_mesh(bo);
  ASSERT_TRUE(build_topology(m).ok());
  int deferred_tets = 0, below_tets = 0;
  for (double thr : {0.3, 0.6, 0.9}) {
    TopoOptions o;
    o.measure = TopoMeasure::Dihedral;
    o.quality_threshold = thr;
    TopoEditor ed(m, o);
    for (int32_t t = 0; t < m.nt(); ++t) {
      const int32_t* v = m.tet(t);
      double d[6];
      dihedral_angles(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3]), d);
      double q = 1e300;
      for (double x : d) q = std::min({q, x / o.dihedral_lo, (180.0 - x) / (180.0 - o.dihedral_hi)});
      below_tets += q < thr;
      ASSERT_EQ(ed.below(t, thr), q < thr) << t << " " << q;
      ASSERT_NEAR(ed.cached_alpha(t), q, 1e-9) << t;
    }
    deferred_tets += ed.deferring();
  }
  EXPECT_GT(deferred_tets, 0);
  EXPECT_GT(below_tets, 0);
}

TEST(Topo, PairSearchUndoesTrialsAroundAnInvertedTet) {
  // An inverted tet that stays (its vertex is required): trials that replace
  // it must be undone to it, inverted as it was, not refused as an invalid
  // plan (which threw before) — and a pair may never create a non-positive tet.
  BoxMeshOptions bo;
  bo.nx = bo.ny = bo.nz = 4;
  bo.jitter = 0.3;
  bo.seed = 4;
  TetMesh m = make_box_mesh(bo);
  ASSERT_TRUE(build_topology(m).ok());
  int32_t v = -1;
  for (int32_t u = 0; u < m.nv() && v < 0; ++u)
    if (!m.vert_constrained[u]) v = u;
  ASSERT_GE(v, 0);
  // Push v through the opposite face of one tet of its star.
  const int32_t t0 = *m.star_begin(v);
  const int32_t* tv = m.tet(t0);
  int lv = 0;
  while (tv[lv] != v) ++lv;
  const double* a = m.point(tv[kFaceVertex[lv][0]]);
  const double* b = m.point(tv[kFaceVertex[lv][1]]);
  const double* c = m.point(tv[kFaceVertex[lv][2]]);
  for (int k = 0; k < 3; ++k) m.point(v)[k] = -0.2 * m.point(v)[k] + 0.4 * (a[k] + b[k] + c[k]);
  m.required_vertices.push_back(v);
  ASSERT_TRUE(build_topology(m).ok());
  const std::vector<int32_t> bad0 = [&] {
    std::vector<int32_t> out;
    for (int32_t t = 0; t < m.nt(); ++t) {
      const int32_t* q = m.tet(t);
      if (orient3d(m.point(q[0]), m.point(q[1]), m.point(q[2]), m.point(q[3])) != Sign::Positive) out.push_back(t);
    }
    return out;
  }();
  ASSERT_FALSE(bad0.empty());
  const Snapshot s = snap(m);
  int refused = 0;
  {
    TopoEditor ed(m, {});
    for (int32_t t = 0; t < m.nt(); ++t) {
      if (!ed.alive(t)) continue;
      const std::vector<int32_t> tets0 = m.tets;
      TopoResult r = TopoResult::NotApplicable;
      ASSERT_NO_THROW(r = ed.improve_tet_pair(t));
      if (r != TopoResult::Applied) {
        ++refused;
        for (size_t i = 0; i < tets0.size(); ++i) ASSERT_EQ(m.tets[i], tets0[i]) << i;
      }
    }
    ed.finish();
  }
  EXPECT_GT(refused, 0);
  int bad1 = 0;
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* q = m.tet(t);
    bad1 += orient3d(m.point(q[0]), m.point(q[1]), m.point(q[2]), m.point(q[3])) != Sign::Positive;
  }
  EXPECT_LE(bad1, static_cast<int>(bad0.size()));
  const Snapshot after = snap(m);
  EXPECT_EQ(s.constrained, after.constrained);
  EXPECT_EQ(s.verts, after.verts);
  ASSERT_EQ(s.volumes.size(), after.volumes.size());
  for (size_t i = 0; i < s.volumes.size(); ++i)
    EXPECT_NEAR(s.volumes[i].second, after.volumes[i].second, 1e-12 * std::fabs(s.volumes[i].second));
}

TEST(Improve, BestModeWidensGammaToTheAffordableSetOnAGenerallyPoorMesh) {
  // A jittered 30^3 box (162k tets, a tenth of them below alpha 0.3): gamma
  // 0.4 -> 0.5 would put too many tets in play (kWideFraction / kWideMin),
  // and the run used to stop with the worst alpha exactly at 0.4000.  Now
  // gamma rises to the alpha below which the affordable number of tets lie
  // while the worst tet has a free vertex and the widened rounds pay
  // (0.5087 in 10 rounds here).
  TetMesh m = make_box_mesh({.nx = 30, .ny = 30, .nz = 30, .jitter = 0.45, .seed = 1});
  ASSERT_TRUE(build_topology(m).ok());
  ImproveOptions o;
  o.threads = 2;
  ImproveReport r;
  ASSERT_TRUE(improve(m, o, r).ok());
  EXPECT_TRUE(r.invariants_ok);
  EXPECT_GT(r.after.alpha_worst, 0.45);
  EXPECT_GT(r.rounds, 6);
}

namespace {
using tetopt_test::needle_box;

// Tets whose largest dihedral angle exceeds `above` degrees, and the largest.
int tets_above(const TetMesh& m, double above, double* largest) {
  int n = 0;
  *largest = 0;
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = m.tet(t);
    double lo, hi;
    dihedral_extremes(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3]), lo, hi);
    n += hi > above;
    *largest = std::max(*largest, hi);
  }
  return n;
}
}  // namespace

TEST(Topo, DihedralPassBuysNoSmallAngleWithALargeOne) {
  // The dihedral measure rates an angle of 179.5 degrees like one of 0.375:
  // beside needle boundary triangles (worst alpha 0.001, the pass's floor)
  // the pass raised the needle tets' smallest angles by making new tets with
  // angles of 170-178 degrees (this box: none above 170 before, 15 after).
  // TopoOptions::angle_keep = 170 forbids adding any.
  int moved = 0;
  const TetMesh m0 = [&] {
    TetMesh m = needle_box(8, 4, 1, &moved);
    EXPECT_TRUE(build_topology(m).ok());
    return m;
  }();
  ASSERT_GT(moved, 5);
  double largest0 = 0;
  const int above0 = tets_above(m0, 170, &largest0);
  const double a0 = worst_alpha(m0);
  TopoOptions o;
  o.quality_threshold = 0.3;
  o.passes = 2;
  o.alpha_keep = 0.02;  // as mode best runs it
  for (const double keep : {0.0, 170.0}) {
    SCOPED_TRACE(keep);
    TetMesh m = m0;
    Snapshot s = snap(m);
    o.angle_keep = keep;
    const TopoStats st = dihedral_pass(m, o);
    ASSERT_TRUE(st.status.ok());
    EXPECT_GT(st.applied() + st.vertex_moves, 0);
    EXPECT_GE(worst_alpha(m), a0);
    double largest = 0;
    const int above = tets_above(m, 170, &largest);
    if (keep == 0) {
      EXPECT_GT(above, above0 + 5);  // what the rule is for
    } else {
      EXPECT_LE(above, above0);
      EXPECT_LE(largest, std::max(largest0, 170.0));
    }
    s.xyz = m.xyz;  // free vertices move; constrained ones are checked below
    expect_invariants(s, m);
    for (int32_t v = 0; v < m.nv(); ++v) {
      if (!m.vert_constrained[v]) continue;
      for (int k = 0; k < 3; ++k) EXPECT_EQ(m.point(v)[k], m0.point(v)[k]) << v;
    }
  }
}

TEST(Improve, DihedralPassAddsNoPoorTetsBesideNeedleBoundaryTriangles) {
  // Tets on needle boundary triangles cannot reach a good alpha whatever
  // their apex (a thin vessel wall meshed coarsely: aorta_vessel), so the
  // worst alpha stays near 0.001.  Mode best's last pass (dihedral angles)
  // had only that worst alpha as its floor and put new tets just above it
  // beside good ones: this box went from 127 tets below alpha 0.1 to 459,
  // and from 127 tets with an angle below 5 degrees to 427
  // (TopoOptions::alpha_keep now stops that).
  int moved = 0;
  TetMesh m = needle_box(12, 6, 3, &moved);
  ASSERT_GT(moved, 20);
  ASSERT_TRUE(build_topology(m).ok());
  const Snapshot s = snap(m);
  ImproveOptions o;
  o.threads = 2;
  ImproveReport r;
  ASSERT_TRUE(improve(m, o, r).ok());
  EXPECT_TRUE(r.invariants_ok);
  ASSERT_GT(r.before.alpha_below_01, 100);
  EXPECT_LT(r.after.alpha_worst, 0.01);  // the needles' tets stay poor
  EXPECT_LE(r.after.alpha_below_01, r.before.alpha_below_01);
  EXPECT_LE(r.after.dihedral_below_5, r.before.dihedral_below_5);
  EXPECT_GT(r.after.alpha_mean, r.before.alpha_mean);
  const Snapshot after = snap(m);
  EXPECT_EQ(s.constrained, after.constrained);
  ASSERT_EQ(s.volumes.size(), after.volumes.size());
  for (size_t k = 0; k < s.volumes.size(); ++k)
    EXPECT_NEAR(s.volumes[k].second, after.volumes[k].second, 1e-12 * std::fabs(s.volumes[k].second));
  // Constrained vertices bit-identical.
  for (int32_t v = 0; v < m.nv(); ++v) {
    if (!m.vert_constrained[v]) continue;
    for (int k = 0; k < 3; ++k) EXPECT_EQ(m.point(v)[k], s.xyz[3 * static_cast<size_t>(v) + k]) << v;
  }
}

// plan_edge's DP takes its tets' alpha from memoised pieces
// (detail::ShellAlpha); each must be alpha() of the same tet bit for bit,
// or the DP would pick triangulations by numbers the rest of the engine
// does not see.  Rings of 3 to 16 points around an edge (a, b), jittered,
// some near-flat, every triangle (i, k, j) of each, top and bottom.
TEST(Topo, ShellAlphaIsAlphaBitForBit) {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(-1, 1);
  int64_t checked = 0, positive = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 3 + trial % 14;
    TetMesh m;
    const double flat = trial % 3 == 0 ? 1e-7 : 0.3;
    for (int s = 0; s < n; ++s) {
      const double th = 2 * M_PI * s / n + 0.2 * u(rng);
      m.xyz.insert(m.xyz.end(), {std::cos(th) + 0.1 * u(rng), std::sin(th) + 0.1 * u(rng), flat * u(rng)});
    }
    const double a[3] = {0.1 * u(rng), 0.1 * u(rng), 1 + 0.5 * u(rng)};
    const double b[3] = {0.1 * u(rng), 0.1 * u(rng), -1 + 0.5 * u(rng)};
    std::vector<int32_t> ring(n);
    for (int s = 0; s < n; ++s) ring[s] = s;
    detail::ShellAlpha sa;
    sa.reset(n, ring.data(), a, b, m);
    auto bits = [](double x, double y) { return std::memcmp(&x, &y, sizeof x) == 0; };
    for (int i = 0; i < n; ++i)
      for (int k = i + 1; k < n; ++k)
        for (int j = k + 1; j < n; ++j) {
          const double *pi = m.point(i), *pk = m.point(k), *pj = m.point(j);
          const double top = sa.top(i, k, j), want_top = alpha(pi, pk, pj, b);
          const double bottom = sa.bottom(i, k, j), want_bottom = alpha(pi, pj, pk, a);
          EXPECT_TRUE(bits(top, want_top)) << trial << ": " << top << " vs " << want_top;
          EXPECT_TRUE(bits(bottom, want_bottom)) << trial << ": " << bottom << " vs " << want_bottom;
          checked += 2;
          positive += (top > 0) + (bottom > 0);
        }
  }
  EXPECT_GT(checked, 10000);
  EXPECT_GT(positive, 1000);  // both orientations met
  EXPECT_LT(positive, checked);
}

// TopoOptions::alpha_keep under the alpha measure (the flips at the bound,
// improve.cpp, Driver::polish_at_bound): the 2-3 of TwoThreeAddsEdge raises
// the worst alpha (two flat tets become three better ones), but with a
// level above the new tets' alpha it leaves three tets below the level
// where there were two, so alpha_keep at that level refuses it; at a level
// below the old tets' alpha it is taken.
TEST(Topo, AlphaKeepHoldsForTheAlphaMeasureFlips) {
  auto p = ring_points(3, 2.0, 0.3);
  const TetMesh base = make_mesh(p, {{0, 2, 3, 4}, {1, 2, 3, 4}});
  const double a = worst_alpha(base);
  int lf = 0;
  while (base.adj[lf] < 0) ++lf;
  TetMesh plain = base;
  ASSERT_EQ(flip_23(plain, 0, lf), TopoResult::Applied);
  const double b = worst_alpha(plain);
  ASSERT_GT(b, a);
  for (int32_t t = 0; t < 3; ++t) ASSERT_LT(tet_alpha(plain, t), b + 0.01);
  TopoOptions o;
  {
    TetMesh m = base;
    o.alpha_keep = b + 0.01;  // two tets below it before, three after
    TopoEditor ed(m, o);
    EXPECT_EQ(ed.flip_23(0, lf), TopoResult::NotImproved);
    ed.finish();
    EXPECT_EQ(m.tets, base.tets);
  }
  {
    TetMesh m = base;
    o.alpha_keep = 0.5 * a;  // none below it either way
    TopoEditor ed(m, o);
    EXPECT_EQ(ed.flip_23(0, lf), TopoResult::Applied);
    ed.finish();
    EXPECT_EQ(m.nt(), 3);
  }
}
