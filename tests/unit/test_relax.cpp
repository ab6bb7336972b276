// Tests of the global relaxation (relax.hpp) on a lazy random triangulation
// of the unit cube built here (the RAND meshes of Freitag & Ollivier-Gooch:
// every new vertex only splits the tet that holds it) and on box meshes.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "tetopt/generate.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/predicates.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/relax.hpp"

namespace tetopt {
namespace {

// Kuhn split of [0,1]^3, then n - 8 random interior points, each splitting
// the tet that strictly contains it into four (points that fall on a face
// are redrawn).  Only the 8 corners are constrained.
TetMesh lazy_random_cube(int n, uint64_t seed) {
  TetMesh m;
  const double c[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  for (const auto& p : c) m.xyz.insert(m.xyz.end(), p, p + 3);
  const int32_t kuhn[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6}, {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
  for (const auto& t : kuhn) {
    int32_t q[4] = {t[0], t[1], t[2], t[3]};
    if (!is_positive(m.point(q[0]), m.point(q[1]), m.point(q[2]), m.point(q[3]))) std::swap(q[0], q[1]);
    m.tets.insert(m.tets.end(), q, q + 4);
  }
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  while (m.nv() < n) {
    const double p[3] = {u(rng), u(rng), u(rng)};
    for (int32_t t = 0; t < m.nt(); ++t) {
      const int32_t* q = m.tet(t);
      bool inside = true;
      for (int f = 0; f < 4 && inside; ++f) {
        const double* x[4] = {m.point(q[0]), m.point(q[1]), m.point(q[2]), m.point(q[3])};
        x[f] = p;
        inside = is_positive(x[0], x[1], x[2], x[3]);
      }
      if (!inside) continue;
      const int32_t v = m.nv();
      m.xyz.insert(m.xyz.end(), p, p + 3);
      const int32_t old[4] = {q[0], q[1], q[2], q[3]};
      for (int f = 0; f < 4; ++f) {
        int32_t s[4] = {old[0], old[1], old[2], old[3]};
        s[f] = v;
        if (f == 0) std::copy(s, s + 4, &m.tets[4 * static_cast<size_t>(t)]);
        else m.tets.insert(m.tets.end(), s, s + 4);
      }
      break;
    }
  }
  m.tet_ref.assign(static_cast<size_t>(m.nt()), 1);
  m.vert_ref.assign(static_cast<size_t>(m.nv()), 0);
  return m;
}

struct Extremes {
  double dmin = 180, dmax = 0, amin = 1, amean = 0;
};

Extremes extremes(const TetMesh& m) {
  Extremes e;
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* q = m.tet(t);
    double d[6];
    dihedral_angles(m.point(q[0]), m.point(q[1]), m.point(q[2]), m.point(q[3]), d);
    for (double x : d) { e.dmin = std::min(e.dmin, x); e.dmax = std::max(e.dmax, x); }
    const double a = tet_alpha(m, t);
    e.amin = std::min(e.amin, a);
    e.amean += a / m.nt();
  }
  return e;
}

double total_volume(const TetMesh& m) {
  double v = 0;
  for (int32_t t = 0; t < m.nt(); ++t) v += tet_volume(m, t);
  return v;
}

// Runs relax_pass and checks every promise of relax.hpp; returns the stats.
RelaxStats relax_and_check(TetMesh& m, const RelaxOptions& o, uint64_t seed) {
  std::vector<int32_t> fixed;
  std::vector<double> fixed_xyz;
  for (int32_t v = 0; v < m.nv(); ++v)
    if (m.vert_constrained[v]) {
      fixed.push_back(v);
      fixed_xyz.insert(fixed_xyz.end(), m.point(v), m.point(v) + 3);
    }
  std::vector<std::array<int32_t, 3>> faces_before;
  auto constrained_faces = [](const TetMesh& mm) {
    std::vector<std::array<int32_t, 3>> out;
    for (int32_t t = 0; t < mm.nt(); ++t)
      for (int f = 0; f < 4; ++f)
        if (mm.face_mask[t] & (1u << f)) {
          int32_t k[3];
          face_key(mm, t, f, k);
          out.push_back({k[0], k[1], k[2]});
        }
    std::sort(out.begin(), out.end());
    return out;
  };
  faces_before = constrained_faces(m);
  const double vol = total_volume(m);

  const RelaxStats st = relax_pass(m, o);
  EXPECT_TRUE(st.status.ok()) << st.status.message << " seed " << seed;
  const Status v = validate(m, ValidateLevel::Full);
  EXPECT_TRUE(v.ok()) << v.message << " seed " << seed;
  for (size_t i = 0; i < fixed.size(); ++i)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(std::memcmp(&m.point(fixed[i])[k], &fixed_xyz[3 * i + k], sizeof(double)), 0)
          << "constrained vertex " << fixed[i] << " moved, seed " << seed;
  EXPECT_EQ(constrained_faces(m), faces_before) << "seed " << seed;
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* q = m.tet(t);
    EXPECT_EQ(orient3d(m.point(q[0]), m.point(q[1]), m.point(q[2]), m.point(q[3])), Sign::Positive)
        << "tet " << t << " seed " << seed;
  }
  EXPECT_NEAR(total_volume(m), vol, 1e-9 * vol) << "seed " << seed;
  return st;
}

TEST(RelaxTest, LazyRandomCubeImprovesAndKeepsPromises) {
  for (uint64_t seed : {1u, 2u, 3u}) {
    TetMesh m = lazy_random_cube(400, seed);
    ASSERT_TRUE(build_topology(m).ok());
    ASSERT_EQ(std::count(m.vert_constrained.begin(), m.vert_constrained.end(), 1), 8);
    EXPECT_TRUE(relax_wanted(m)) << "a lazy random mesh is globally bad, seed " << seed;
    const Extremes before = extremes(m);
    RelaxOptions o;
    o.rounds = 8;
    const RelaxStats st = relax_and_check(m, o, seed);
    const Extremes after = extremes(m);
    EXPECT_GT(st.moves, 0);
    EXPECT_GT(st.flips, 0);
    EXPECT_GT(after.dmin, before.dmin) << "seed " << seed;
    EXPECT_LT(after.dmax, before.dmax) << "seed " << seed;
    EXPECT_GT(after.amin, before.amin) << "seed " << seed;
    EXPECT_GT(after.amean, 2 * before.amean) << "seed " << seed;
    EXPECT_NEAR(st.alpha_mean_after, after.amean, 1e-9);
  }
}

TEST(RelaxTest, JitteredBoxKeepsPromises) {
  BoxMeshOptions bo;
  bo.nx = bo.ny = bo.nz = 5;
  bo.jitter = 0.45;
  bo.seed = 7;
  bo.regions = 2;
  TetMesh m = make_box_mesh(bo);
  ASSERT_TRUE(build_topology(m).ok());
  RelaxOptions o;
  o.rounds = 4;
  const Extremes before = extremes(m);
  relax_and_check(m, o, 7);
  const Extremes after = extremes(m);
  EXPECT_GE(after.amean, before.amean);
}

TEST(RelaxTest, TriggerIgnoresGoodMeshes) {
  BoxMeshOptions bo;
  bo.nx = bo.ny = bo.nz = 4;
  TetMesh m = make_box_mesh(bo);
  ASSERT_TRUE(build_topology(m).ok());
  EXPECT_EQ(bad_tet_fraction(m), 0.0);
  EXPECT_FALSE(relax_wanted(m));
}

// RelaxOptions::threads runs the flip passes' planning in parallel: the
// mesh after the pass is the same, bit for bit, for every thread count.
TEST(RelaxTest, TheSameMeshForEveryThreadCount) {
  const TetMesh m0 = [] {
    TetMesh m = lazy_random_cube(1500, 5);
    EXPECT_TRUE(build_topology(m).ok());
    return m;
  }();
  RelaxOptions o;
  o.rounds = 4;
  TetMesh one = m0;
  const RelaxStats s1 = relax_pass(one, o);
  ASSERT_TRUE(s1.status.ok());
  ASSERT_GT(s1.flips, 0);
  for (int threads : {2, 3, 0}) {
    TetMesh m = m0;
    o.threads = threads;
    const RelaxStats st = relax_pass(m, o);
    ASSERT_TRUE(st.status.ok());
    EXPECT_EQ(st.flips, s1.flips) << threads << " threads";
    EXPECT_EQ(m.tets, one.tets) << threads << " threads";
    EXPECT_EQ(m.xyz, one.xyz) << threads << " threads";
  }
}

TEST(RelaxTest, BadFractionIsTheSameForEveryThreadCount) {
  // Several blocks of 8192 tets, so the threads split the count.
  BoxMeshOptions bo;
  bo.nx = bo.ny = bo.nz = 17;
  bo.jitter = 0.45;
  bo.seed = 3;
  TetMesh m = make_box_mesh(bo);
  ASSERT_TRUE(build_topology(m).ok());
  ASSERT_GT(m.nt(), 3 * 8192);
  int64_t bad = 0;
  for (int32_t t = 0; t < m.nt(); ++t) bad += alpha(m.point(m.tet(t)[0]), m.point(m.tet(t)[1]), m.point(m.tet(t)[2]),
                                                    m.point(m.tet(t)[3])) < 0.1;
  ASSERT_GT(bad, 0);
  ASSERT_LT(bad, m.nt());
  const double expect = static_cast<double>(bad) / m.nt();
  for (int threads : {1, 2, 3, 0}) EXPECT_EQ(bad_tet_fraction(m, threads), expect) << threads << " threads";
}

TEST(RelaxTest, SizeFieldIsLargeNearBigConstrainedFaces) {
  TetMesh m = lazy_random_cube(300, 5);
  ASSERT_TRUE(build_topology(m).ok());
  const double g = 1.0;
  const std::vector<double> h = relax_size_field(m, g);
  ASSERT_EQ(static_cast<int32_t>(h.size()), m.nv());
  double h_min = INFINITY, near = 0, centre = INFINITY;
  for (int32_t v = 0; v < m.nv(); ++v) {
    h_min = std::min(h_min, h[v]);
    const double* p = m.point(v);
    const double depth = std::min({p[0], p[1], p[2], 1 - p[0], 1 - p[1], 1 - p[2]});
    if (m.vert_constrained[v]) continue;
    if (depth < 0.05) near = std::max(near, h[v]);
    if (depth > 0.4) centre = std::min(centre, h[v]);
  }
  EXPECT_GT(h_min, 0);
  // Faces have mean edge length (2 + sqrt 2) / 3; h falls by at most g per
  // unit of distance from them.
  const double hf = (2 + std::sqrt(2.0)) / 3;
  EXPECT_GT(near, hf - 0.05 * g - 1e-12);
  EXPECT_LE(near, hf + 1e-12);
  EXPECT_LT(centre, near);
}

}  // namespace
}  // namespace tetopt
