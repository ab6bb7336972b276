// Smoothing with the paper's weight C: objective, gradients, optimisers and
// pass invariants (smooth.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>
#include <vector>

#include "tetopt/conventions.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/improve.hpp"
#include "tetopt/io.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/predicates.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/smooth.hpp"
#include "detail/star_errors.hpp"

using namespace tetopt;

namespace {

TetMesh box(int n, double jitter, uint64_t seed = 7, int regions = 1) {
  BoxMeshOptions bo;
  bo.nx = bo.ny = bo.nz = n;
  bo.jitter = jitter;
  bo.seed = seed;
  bo.regions = regions;
  TetMesh m = make_box_mesh(bo);
  Status s = build_topology(m);
  EXPECT_TRUE(s.ok()) << s.message;
  return m;
}

int32_t lattice_vertex(int n, int i, int j, int k) { return (k * (n + 1) + j) * (n + 1) + i; }

double worst_alpha(const TetMesh& m) {
  double w = INFINITY;
  for (int32_t t = 0; t < m.nt(); ++t) w = std::min(w, tet_alpha(m, t));
  return w;
}

double total_volume(const TetMesh& m) {
  double v = 0;
  for (auto& [ref, vol] : region_volumes(m)) v += vol;
  return v;
}

int64_t non_positive_tets(const TetMesh& m) {
  int64_t bad = 0;
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = m.tet(t);
    bad += orient3d(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3])) != Sign::Positive;
  }
  return bad;
}

// Bitwise comparison of the coordinates of every constrained vertex.
int64_t constrained_changed(const TetMesh& before, const TetMesh& after) {
  int64_t changed = 0;
  for (int32_t v = 0; v < before.nv(); ++v)
    if (before.vert_constrained[v] && std::memcmp(before.point(v), after.point(v), 3 * sizeof(double)) != 0)
      ++changed;
  return changed;
}

double max_displacement(const TetMesh& a, const TetMesh& b) {
  double d = 0;
  for (size_t i = 0; i < a.xyz.size(); ++i) d = std::max(d, std::fabs(a.xyz[i] - b.xyz[i]));
  return d;
}

// A random positive tet with coordinates in [-1, 1].
void random_tet(std::mt19937_64& rng, double p[4][3]) {
  std::uniform_real_distribution<double> u(-1, 1);
  for (;;) {
    for (int i = 0; i < 4; ++i)
      for (int k = 0; k < 3; ++k) p[i][k] = u(rng);
    if (alpha(p[0], p[1], p[2], p[3]) > 0.05) return;
    if (alpha(p[0], p[1], p[3], p[2]) > 0.05) {
      for (int k = 0; k < 3; ++k) std::swap(p[2][k], p[3][k]);
      return;
    }
  }
}

}  // namespace

TEST(SmoothObjective, RegularTetErrorIsOneAndMatchesAlpha) {
  const double s = 1.0 / std::sqrt(2.0);
  double p[4][3] = {{1, 0, -s}, {-1, 0, -s}, {0, 1, s}, {0, -1, s}};
  if (alpha(p[0], p[1], p[2], p[3]) < 0) std::swap(p[2], p[3]);
  const double* q[4] = {p[0], p[1], p[2], p[3]};
  double g[3];
  for (int w = 0; w < 4; ++w) {
    EXPECT_NEAR(tet_error_and_gradient(q, w, g), 1.0, 1e-14);
    EXPECT_TRUE(std::isfinite(g[0]) && std::isfinite(g[1]) && std::isfinite(g[2]));
  }
  std::mt19937_64 rng(3);
  for (int trial = 0; trial < 50; ++trial) {
    double r[4][3];
    random_tet(rng, r);
    const double* rq[4] = {r[0], r[1], r[2], r[3]};
    for (int w = 0; w < 4; ++w)
      EXPECT_NEAR(tet_error_and_gradient(rq, w, g), 1.0 / alpha(r[0], r[1], r[2], r[3]),
                  1e-12 / alpha(r[0], r[1], r[2], r[3]));
  }
  // Inverted: infinite error, zero gradient.
  const double* inv[4] = {p[0], p[1], p[3], p[2]};
  EXPECT_EQ(tet_error_and_gradient(inv, 0, g), INFINITY);
  EXPECT_EQ(g[0], 0.0);
}

TEST(SmoothObjective, GradientMatchesFiniteDifferences) {
  std::mt19937_64 rng(11);
  int checked = 0;
  for (int trial = 0; trial < 200; ++trial) {
    double p[4][3];
    random_tet(rng, p);
    // Skip tets whose two longest edges are nearly tied (switching points).
    double l[6];
    for (int e = 0; e < 6; ++e) {
      const double* a = p[kEdgeVertex[e][0]];
      const double* b = p[kEdgeVertex[e][1]];
      l[e] = std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    }
    std::sort(l, l + 6);
    if (l[5] - l[4] < 1e-3 * l[5]) continue;
    for (int w = 0; w < 4; ++w) {
      double q[4][3];
      std::memcpy(q, p, sizeof q);
      const double* qp[4] = {q[0], q[1], q[2], q[3]};
      double g[3], dummy[3];
      const double e = tet_error_and_gradient(qp, w, g);
      const double h = 1e-6;
      for (int k = 0; k < 3; ++k) {
        const double x0 = q[w][k];
        q[w][k] = x0 + h;
        const double ep = tet_error_and_gradient(qp, w, dummy);
        q[w][k] = x0 - h;
        const double em = tet_error_and_gradient(qp, w, dummy);
        q[w][k] = x0;
        const double fd = (ep - em) / (2 * h);
        EXPECT_NEAR(g[k], fd, 1e-5 * (std::fabs(fd) + e)) << "trial " << trial << " vertex " << w << " axis " << k;
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 300);
}

TEST(SmoothObjective, VertexObjectiveIsWeightedSumOfInverseAlpha) {
  TetMesh m = box(4, 0.3);
  int mixed = 0;
  for (int32_t v = 0; v < m.nv(); ++v) {
    if (m.vert_constrained[v]) continue;
    for (double C : {0.5, 0.75, 0.9}) {
      double ref = 0;
      bool has_b = false, has_i = false;
      for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it) {
        const bool b = m.tet_kind[*it] > 0;
        has_b |= b;
        has_i |= !b;
        ref += (b ? C : 1 - C) / tet_alpha(m, *it);
      }
      mixed += has_b && has_i;
      EXPECT_NEAR(vertex_objective(m, v, C), ref, 1e-12 * ref);
    }
  }
  EXPECT_GT(mixed, 0);  // stars with both kinds exist, so the weights were exercised
}

TEST(SmoothLattice, RegularLatticeIsFixedPoint) {
  for (Optimizer opt : {Optimizer::Paper, Optimizer::MaxMin}) {
    TetMesh m = box(6, 0.0);
    const TetMesh before = m;
    SmoothOptions o;
    o.weight = 0.5;  // uniform weights: every interior star is centrally symmetric
    o.threshold = 2.0;
    o.all_vertices = true;
    o.optimizer = opt;
    const SmoothStats st = smooth_pass(m, o);
    EXPECT_GT(st.moves_tried, 0);
    EXPECT_LE(max_displacement(before, m), 1e-6) << "optimizer " << static_cast<int>(opt);
  }
  // With C = 0.75 a vertex whose star is all interior is still a fixed point.
  TetMesh m = box(6, 0.0);
  const int32_t v = lattice_vertex(6, 3, 3, 3);
  for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it) ASSERT_EQ(m.tet_kind[*it], 0);
  const double p0[3] = {m.point(v)[0], m.point(v)[1], m.point(v)[2]};
  SmoothOptions o;
  smooth_vertex(m, v, o);
  EXPECT_LE(std::hypot(m.point(v)[0] - p0[0], m.point(v)[1] - p0[1], m.point(v)[2] - p0[2]), 1e-6);
}

TEST(SmoothLattice, DisplacedVertexReturnsToOptimum) {
  for (Optimizer opt : {Optimizer::Paper, Optimizer::MaxMin}) {
    TetMesh m = box(6, 0.0);
    const int32_t v = lattice_vertex(6, 3, 3, 3);
    double* p = m.point(v);
    p[0] += 0.2; p[1] -= 0.15; p[2] += 0.1;
    const double f0 = vertex_objective(m, v, 0.75);
    SmoothOptions o;
    o.optimizer = opt;
    o.max_steps = 50;
    o.line_tol = 1e-7;
    int applied = 0;
    for (int rep = 0; rep < 5; ++rep) applied += smooth_vertex(m, v, o) == SmoothResult::Applied;
    EXPECT_GT(applied, 0);
    EXPECT_LT(vertex_objective(m, v, 0.75), f0);
    // By symmetry of the Kuhn star the optimum is the lattice point (3,3,3).
    EXPECT_LT(std::hypot(p[0] - 3, p[1] - 3, p[2] - 3), 2e-3) << "optimizer " << static_cast<int>(opt) << " at "
                                                              << p[0] << " " << p[1] << " " << p[2];
  }
}

TEST(SmoothVertex, ObjectiveNeverIncreasesAndConstrainedLocked) {
  TetMesh m = box(6, 0.38, 5);
  std::vector<int32_t> order(m.nv());
  for (int32_t v = 0; v < m.nv(); ++v) order[v] = v;
  std::mt19937_64 rng(1);
  std::shuffle(order.begin(), order.end(), rng);
  SmoothOptions o;
  int applied = 0, locked = 0;
  double fm = mesh_objective(m, o.weight);
  for (int32_t v : order) {
    const double f0 = vertex_objective(m, v, o.weight);
    const double w0 = [&] {
      double w = INFINITY;
      for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it) w = std::min(w, tet_alpha(m, *it));
      return w;
    }();
    double keep[3];
    std::memcpy(keep, m.point(v), sizeof keep);
    const SmoothResult r = smooth_vertex(m, v, o);
    const double f1 = vertex_objective(m, v, o.weight);
    if (r == SmoothResult::Applied) {
      ++applied;
      EXPECT_LE(f1, f0 * (1 - o.margin));
      double w1 = INFINITY;
      for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it) w1 = std::min(w1, tet_alpha(m, *it));
      EXPECT_GE(w1, w0);
    } else {
      EXPECT_EQ(std::memcmp(keep, m.point(v), sizeof keep), 0);
      EXPECT_EQ(f1, f0);
    }
    if (m.vert_constrained[v]) {
      ++locked;
      EXPECT_EQ(r, SmoothResult::BoundaryLocked);
    }
    const double fm1 = mesh_objective(m, o.weight);
    EXPECT_LE(fm1, fm * (1 + 1e-13));
    fm = fm1;
  }
  EXPECT_GT(applied, 10);
  EXPECT_GT(locked, 10);
  EXPECT_EQ(non_positive_tets(m), 0);
}

namespace {
void check_pass_invariants(Optimizer opt, uint64_t seed) {
  TetMesh m = box(10, 0.38, seed);
  const TetMesh before = m;
  const double vol0 = total_volume(m);
  const double w0 = worst_alpha(m);
  // The worst tet has a free vertex, so smoothing can improve it.
  const QualityStats s0 = compute_stats(m);
  ASSERT_LT(m.tet_kind[s0.worst_tet], 4);
  SmoothOptions o;
  o.optimizer = opt;
  o.seed = seed;
  const SmoothStats st = smooth_pass(m, o);
  EXPECT_EQ(constrained_changed(before, m), 0);
  EXPECT_EQ(non_positive_tets(m), 0);
  EXPECT_NEAR(total_volume(m), vol0, 1e-12 * vol0);
  const double w1 = worst_alpha(m);
  EXPECT_EQ(st.worst_alpha_before, w0);
  EXPECT_EQ(st.worst_alpha_after, w1);
  EXPECT_GT(w1, w0 + 0.01) << "optimizer " << static_cast<int>(opt);
  EXPECT_LE(st.objective_after, st.objective_before);
  if (opt == Optimizer::Paper) {
    EXPECT_LT(st.objective_after, 0.99 * st.objective_before);
  }
  EXPECT_GT(st.moves_applied, 100);
  EXPECT_GT(max_displacement(before, m), 0.01);  // something actually moved
  EXPECT_TRUE(validate(m).ok());
}
}  // namespace

TEST(SmoothPass, InvariantsPaperOptimizer) { check_pass_invariants(Optimizer::Paper, 21); }
TEST(SmoothPass, InvariantsMaxMinOptimizer) { check_pass_invariants(Optimizer::MaxMin, 22); }

TEST(SmoothPass, AllVerticesPhaseImprovesFurther) {
  TetMesh a = box(8, 0.35, 9), b = a;
  SmoothOptions o;
  smooth_pass(a, o);
  o.all_vertices = true;
  const SmoothStats st = smooth_pass(b, o);
  EXPECT_LE(st.objective_after, mesh_objective(a, o.weight));
  EXPECT_EQ(non_positive_tets(b), 0);
}

TEST(SmoothPass, TwoRegionInterfaceVerticesDoNotMove) {
  const int n = 8;
  TetMesh m = box(n, 0.38, 4, 2);
  const TetMesh before = m;
  int interface = 0;
  for (int k = 1; k < n; ++k)
    for (int j = 1; j < n; ++j) {
      const int32_t v = lattice_vertex(n, n / 2, j, k);
      ASSERT_TRUE(m.vert_constrained[v]) << "interface vertex " << v << " not constrained";
      ++interface;
    }
  SmoothOptions o;
  o.all_vertices = true;
  const SmoothStats st = smooth_pass(m, o);
  EXPECT_GT(st.moves_applied, 50);
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j) {
      const int32_t v = lattice_vertex(n, n / 2, j, k);
      EXPECT_EQ(std::memcmp(before.point(v), m.point(v), 3 * sizeof(double)), 0) << "vertex " << v;
    }
  EXPECT_EQ(constrained_changed(before, m), 0);
  EXPECT_EQ(non_positive_tets(m), 0);
  // Region volumes are conserved separately: the interface did not move.
  const auto r0 = region_volumes(before), r1 = region_volumes(m);
  ASSERT_EQ(r0.size(), 2u);
  for (size_t i = 0; i < r0.size(); ++i) EXPECT_NEAR(r1[i].second, r0[i].second, 1e-12 * r0[i].second);
  EXPECT_GT(interface, 0);
}

TEST(SmoothPass, SameSeedGivesIdenticalBytes) {
  for (Optimizer opt : {Optimizer::Paper, Optimizer::MaxMin}) {
    TetMesh a = box(8, 0.38, 3), b = a, c = a;
    SmoothOptions o;
    o.optimizer = opt;
    o.seed = 1234;
    o.all_vertices = true;
    smooth_pass(a, o);
    smooth_pass(b, o);
    ASSERT_EQ(a.xyz.size(), b.xyz.size());
    EXPECT_EQ(std::memcmp(a.xyz.data(), b.xyz.data(), a.xyz.size() * sizeof(double)), 0);
    o.seed = 99;
    smooth_pass(c, o);
    // Gauss-Seidel sweeps depend on the visiting order, so the seed matters.
    EXPECT_NE(std::memcmp(a.xyz.data(), c.xyz.data(), a.xyz.size() * sizeof(double)), 0);
  }
}

TEST(SmoothWeight, HalfEqualsUnweightedSmoothing) {
  // Plain smoothing (every tet weighted alike) = the same mesh with every tet
  // declared interior; weight 0.75 then gives each tet 1 - C = 0.25, a power
  // of two times the 0.5 of C = 0.5, so the runs must agree bit for bit.
  TetMesh a = box(8, 0.38, 13);
  TetMesh plain = a;
  std::fill(plain.tet_kind.begin(), plain.tet_kind.end(), 0);
  for (int32_t v = 0; v < a.nv(); ++v)
    if (!a.vert_constrained[v]) {
      double ref = 0;
      for (const int32_t* it = a.star_begin(v); it != a.star_end(v); ++it) ref += 1.0 / tet_alpha(a, *it);
      EXPECT_NEAR(vertex_objective(a, v, 0.5), 0.5 * ref, 1e-12 * ref);
    }
  TetMesh heavy = a;
  SmoothOptions o;
  o.all_vertices = true;
  o.weight = 0.5;
  smooth_pass(a, o);
  o.weight = 0.75;
  smooth_pass(plain, o);
  EXPECT_EQ(std::memcmp(a.xyz.data(), plain.xyz.data(), a.xyz.size() * sizeof(double)), 0);
  // Control: a real boundary weight changes the result.
  o.weight = 0.9;
  smooth_pass(heavy, o);
  EXPECT_NE(std::memcmp(a.xyz.data(), heavy.xyz.data(), a.xyz.size() * sizeof(double)), 0);
}

TEST(SmoothVertex, ConstrainedVertexIsLocked) {
  TetMesh m = box(4, 0.3);
  // Perturb nothing: a corner vertex is constrained.
  const int32_t v = lattice_vertex(4, 0, 0, 0);
  ASSERT_TRUE(m.vert_constrained[v]);
  const TetMesh before = m;
  for (Optimizer opt : {Optimizer::Paper, Optimizer::MaxMin}) {
    SmoothOptions o;
    o.optimizer = opt;
    EXPECT_EQ(smooth_vertex(m, v, o), SmoothResult::BoundaryLocked);
  }
  EXPECT_EQ(std::memcmp(before.xyz.data(), m.xyz.data(), m.xyz.size() * sizeof(double)), 0);
}

TEST(SmoothVertex, TangledStarIsLeftAlone) {
  TetMesh m = box(4, 0.0);
  const int32_t v = lattice_vertex(4, 2, 2, 2);
  m.point(v)[0] += 1.5;  // past its neighbours: some star tets inverted
  const TetMesh before = m;
  SmoothOptions o;
  EXPECT_EQ(smooth_vertex(m, v, o), SmoothResult::Inverted);
  EXPECT_EQ(std::memcmp(before.xyz.data(), m.xyz.data(), m.xyz.size() * sizeof(double)), 0);
}

TEST(SmoothRealMeshes, WorstAlphaNeverDecreases) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(TETOPT_SOURCE_DIR) / ".." / "shared" / "meshes";
  if (!fs::exists(dir)) GTEST_SKIP() << "no " << dir;
  const char* files[] = {"tire/tire.vtk", "hinge_small/hinge_small.mesh", "flange/flange.mesh"};
  int done = 0;
  for (const char* f : files) {
    TetMesh m;
    if (!fs::exists(dir / f) || !read_mesh((dir / f).string(), m).ok() || !build_topology(m).ok()) continue;
    if (non_positive_tets(m) != 0) continue;
    const TetMesh before = m;
    const double w0 = worst_alpha(m);
    SmoothOptions o;
    o.iterations = 3;
    smooth_pass(m, o);
    EXPECT_EQ(constrained_changed(before, m), 0) << f;
    EXPECT_EQ(non_positive_tets(m), 0) << f;
    EXPECT_GE(worst_alpha(m), w0) << f;
    ++done;
  }
  if (done == 0) GTEST_SKIP() << "no real mesh could be read yet";
}

// Parallel sweeps: the colour classes make the result independent of the
// thread count, byte for byte (both optimisers, both phases).  The box is large
// enough that classes exceed the pool's minimum size, so threads really run.
TEST(SmoothParallel, ThreadCountDoesNotChangeBytes) {
  for (Optimizer opt : {Optimizer::Paper, Optimizer::MaxMin}) {
    const TetMesh base = box(16, 0.38, 31);
    std::vector<TetMesh> runs;
    std::vector<SmoothStats> stats;
    for (int threads : {1, 2, 3, 0}) {
      TetMesh m = base;
      SmoothOptions o;
      o.optimizer = opt;
      o.seed = 5;
      o.all_vertices = true;
      o.iterations = 3;
      o.threads = threads;
      stats.push_back(smooth_pass(m, o));
      runs.push_back(std::move(m));
    }
    ASSERT_GT(stats[0].moves_applied, 1000);
    EXPECT_NE(std::memcmp(base.xyz.data(), runs[0].xyz.data(), base.xyz.size() * sizeof(double)), 0);
    for (size_t i = 1; i < runs.size(); ++i) {
      EXPECT_EQ(std::memcmp(runs[0].xyz.data(), runs[i].xyz.data(), base.xyz.size() * sizeof(double)), 0)
          << "run " << i << " optimizer " << static_cast<int>(opt);
      EXPECT_EQ(stats[i].moves_applied, stats[0].moves_applied);
      EXPECT_EQ(stats[i].moves_tried, stats[0].moves_tried);
      EXPECT_EQ(stats[i].objective_after, stats[0].objective_after);
    }
    EXPECT_EQ(non_positive_tets(runs[2]), 0);
  }
}

// The caller-owned alpha cache: filled when empty, kept exact (bit for bit
// tet_alpha) through the pass, and a current cache handed to a second pass
// gives the same bytes as a pass that computes its own.
TEST(SmoothParallel, AlphaCacheStaysExactAndChangesNothing) {
  TetMesh a = box(10, 0.38, 17), b = a;
  SmoothOptions o;
  o.threads = 2;
  std::vector<double> cache;
  const SmoothStats s1 = smooth_pass(a, o, {}, &cache);
  ASSERT_EQ(static_cast<int32_t>(cache.size()), a.nt());
  for (int32_t t = 0; t < a.nt(); ++t) ASSERT_EQ(cache[t], tet_alpha(a, t)) << "tet " << t;
  EXPECT_EQ(s1.worst_alpha_after, worst_alpha(a));
  EXPECT_NEAR(s1.objective_after, mesh_objective(a, o.weight), 1e-12 * s1.objective_after);
  o.optimizer = Optimizer::MaxMin;
  smooth_pass(a, o, {}, &cache);
  for (int32_t t = 0; t < a.nt(); ++t) ASSERT_EQ(cache[t], tet_alpha(a, t)) << "tet " << t;
  o.optimizer = Optimizer::Paper;
  smooth_pass(b, o);
  o.optimizer = Optimizer::MaxMin;
  smooth_pass(b, o);
  EXPECT_EQ(std::memcmp(a.xyz.data(), b.xyz.data(), a.xyz.size() * sizeof(double)), 0);
}

// The line searches' objective four star tets at a time (star_errors4,
// vectorised) must give local_error's bits for every tet: the smoothing
// outputs were checked byte-identical when it came in, and this checks the
// kernel itself, on the stars of a jittered box's free vertices with the
// vertex moved by offsets from tiny to large enough to invert tets.
TEST(Smooth, StarErrorsFourAtATimeAreLocalErrorBitForBit) {
  // A jittered lattice's stars all have 24 tets; the flips of an improve
  // run give stars of other sizes, whose last block of four is padded.
  TetMesh m = box(6, 0.35, 11);
  ImproveReport rep;
  ASSERT_TRUE(improve(m, ImproveOptions{}, rep).ok());
  ensure_vertex_tets(m);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int tried = 0, finite = 0, infinite = 0, sizes_not_4 = 0;
  for (int32_t v = 0; v < m.nv(); ++v) {
    if (m.vert_constrained[v]) continue;
    const int n = static_cast<int>(m.star_end(v) - m.star_begin(v));
    sizes_not_4 += n % 4 != 0;  // the padding lanes are exercised
    for (const double scale : {0.0, 1e-9, 1e-3, 0.05, 0.3, 1.0, 3.0}) {
      const double dx[3] = {scale * u(rng), scale * u(rng), scale * u(rng)};
      int fin = 0;
      EXPECT_EQ(detail::star_errors_mismatches(m, v, dx, 0.75, &fin), 0) << "vertex " << v << " offset " << scale;
      ++tried;
      finite += fin;
      infinite += n - fin;
    }
  }
  // Not vacuous: many stars, finite errors and inverted tets both met.
  EXPECT_GT(tried, 200);
  EXPECT_GT(finite, 10000);
  EXPECT_GT(infinite, 0);
  EXPECT_GT(sizes_not_4, 0);
}
