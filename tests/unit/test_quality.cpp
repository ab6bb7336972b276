// Quality measures: values on known tets and invariances.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "tetopt/generate.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/report.hpp"
#include "tet_shapes.hpp"

using namespace tetopt;

namespace {
// Regular tet with unit edges, positively oriented.
const double R0[3] = {0, 0, 0}, R1[3] = {1, 0, 0}, R2[3] = {0.5, std::sqrt(3.0) / 2, 0},
             R3[3] = {0.5, std::sqrt(3.0) / 6, std::sqrt(2.0 / 3.0)};

void transform(const double in[3], double out[3], double s, double ang, const double tr[3]) {
  const double c = std::cos(ang), sn = std::sin(ang);
  // rotation about z then about x
  const double x = c * in[0] - sn * in[1], y = sn * in[0] + c * in[1], z = in[2];
  const double y2 = c * y - sn * z, z2 = sn * y + c * z;
  out[0] = s * x + tr[0];
  out[1] = s * y2 + tr[1];
  out[2] = s * z2 + tr[2];
}
}  // namespace

TEST(Quality, RegularTet) {
  EXPECT_NEAR(alpha(R0, R1, R2, R3), 1.0, 1e-14);
  EXPECT_NEAR(alpha_error(alpha(R0, R1, R2, R3)), 1.0, 1e-14);
  EXPECT_NEAR(mean_ratio(R0, R1, R2, R3), 1.0, 1e-14);
  EXPECT_NEAR(radius_ratio(R0, R1, R2, R3), 1.0, 1e-13);
  double d[6];
  dihedral_angles(R0, R1, R2, R3, d);
  for (double x : d) EXPECT_NEAR(x, std::acos(1.0 / 3.0) * 180.0 / M_PI, 1e-10);
  EXPECT_NEAR(d[0], 70.5288, 1e-4);
}

TEST(Quality, InvariantUnderSimilarity) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 20; ++trial) {
    double p[4][3];
    for (auto& q : p)
      for (double& x : q) x = u(rng);
    const double a0 = alpha(p[0], p[1], p[2], p[3]);
    double d0[6];
    dihedral_angles(p[0], p[1], p[2], p[3], d0);
    const double tr[3] = {u(rng) * 100, u(rng) * 100, u(rng) * 100};
    const double s = std::exp(3 * u(rng)), ang = 3 * u(rng);
    double q[4][3];
    for (int i = 0; i < 4; ++i) transform(p[i], q[i], s, ang, tr);
    EXPECT_NEAR(alpha(q[0], q[1], q[2], q[3]), a0, 1e-9 * std::max(1.0, std::fabs(a0)));
    double d1[6];
    dihedral_angles(q[0], q[1], q[2], q[3], d1);
    for (int e = 0; e < 6; ++e) EXPECT_NEAR(d1[e], d0[e], 1e-7);
  }
}

TEST(Quality, FlatAndInverted) {
  const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0}, flat[3] = {0.3, 0.3, 0};
  EXPECT_EQ(alpha(a, b, c, flat), 0.0);
  EXPECT_TRUE(std::isinf(alpha_error(alpha(a, b, c, flat))));
  const double d[3] = {0.2, 0.2, 1};
  EXPECT_GT(alpha(a, b, c, d), 0.0);
  EXPECT_LT(alpha(b, a, c, d), 0.0);
  EXPECT_NEAR(alpha(b, a, c, d), -alpha(a, b, c, d), 1e-15);
  EXPECT_TRUE(std::isinf(alpha_error(alpha(b, a, c, d))));
  EXPECT_LT(mean_ratio(b, a, c, d), 0.0);
  // Coincident points: alpha is 0, not NaN.
  EXPECT_EQ(alpha(a, a, a, a), 0.0);
}

TEST(Quality, SliverHasSmallAlphaAndExtremeDihedrals) {
  // Four points near a square's corners, lifted by a tiny height: a sliver.
  const double a[3] = {0, 0, 0}, b[3] = {1, 0, 1e-3}, c[3] = {1, 1, 0}, d[3] = {0, 1, 1e-3};
  const double q = std::fabs(alpha(a, b, c, d));
  EXPECT_LT(q, 0.01);
  double dh[6];
  dihedral_angles(a, b, c, d, dh);
  double mn = 180, mx = 0;
  for (double x : dh) { mn = std::min(mn, x); mx = std::max(mx, x); }
  EXPECT_LT(mn, 1.0);
  EXPECT_GT(mx, 179.0);
}

TEST(Quality, StatsOnBoxMesh) {
  TetMesh m = make_box_mesh({.nx = 3, .ny = 3, .nz = 3, .regions = 2});
  ASSERT_TRUE(build_topology(m).ok());
  const QualityStats s = compute_stats(m);
  EXPECT_EQ(s.tets, m.nt());
  EXPECT_EQ(s.vertices, m.nv());
  EXPECT_EQ(s.regions, 2);
  EXPECT_EQ(s.boundary_tets + s.kind_count[0], s.tets);
  EXPECT_GT(s.alpha_worst, 0.5);  // Kuhn tets are all similar (alpha ~0.717)
  EXPECT_NEAR(s.alpha_worst, s.alpha_mean, 1e-12);
  int64_t h = 0;
  for (auto x : s.alpha_histogram) h += x;
  EXPECT_EQ(h, s.tets);
  int64_t hd = 0;
  for (auto x : s.dihedral_histogram) hd += x;
  EXPECT_EQ(hd, 6 * s.tets);
  EXPECT_NEAR(s.dihedral_min, 45.0, 1e-9);
  EXPECT_NEAR(s.dihedral_max, 90.0, 1e-9);
}

// compute_stats measures every tet in one fused kernel (shared volume, face
// normals, edge lengths); its extremes must be the per-tet functions' values
// bit for bit, and its dihedral bins those of dihedral_angles(), on a mesh
// with every kind of tet: jittered, one moved to flat, one inverted.
TEST(Quality, StatsAreThePerTetMeasuresExactly) {
  TetMesh m = make_box_mesh({.nx = 5, .ny = 4, .nz = 4, .jitter = 0.4, .seed = 7, .regions = 2});
  ASSERT_TRUE(build_topology(m).ok());
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-0.02, 0.02);
  for (double& x : m.xyz) x += u(rng);  // every vertex, so no angle sits on a bin edge
  {  // tet 5 made exactly flat (its 4th vertex onto the plane of the first three)
    int32_t* v = &m.tets[5 * 4];
    const double *a = m.point(v[0]), *b = m.point(v[1]), *c = m.point(v[2]);
    double* d = &m.xyz[3 * static_cast<size_t>(v[3])];
    for (int k = 0; k < 3; ++k) d[k] = a[k] + 0.25 * (b[k] - a[k]) + 0.5 * (c[k] - a[k]);
  }
  std::swap(m.tets[17 * 4], m.tets[17 * 4 + 1]);  // tet 17 inverted
  double aw = INFINITY, mrw = INFINITY, rrw = INFINITY, dmin = INFINITY, dmax = -INFINITY;
  int32_t worst = -1;
  int64_t flat = 0, small = 0, large = 0;
  std::array<int64_t, 18> hist{};
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = m.tet(t);
    const double *a = m.point(v[0]), *b = m.point(v[1]), *c = m.point(v[2]), *d = m.point(v[3]);
    const double q = alpha(a, b, c, d);
    if (q < aw) { aw = q; worst = t; }
    flat += q <= 0;
    mrw = std::min(mrw, mean_ratio(a, b, c, d));
    rrw = std::min(rrw, radius_ratio(a, b, c, d));
    double dh[6];
    dihedral_angles(a, b, c, d, dh);
    bool s5 = false, l175 = false;
    for (double x : dh) {
      hist[std::min(17, static_cast<int>(x / 10.0))]++;
      dmin = std::min(dmin, x);
      dmax = std::max(dmax, x);
      s5 |= x < 5.0;
      l175 |= x > 175.0;
    }
    small += s5;
    large += l175;
  }
  for (int threads : {1, 2}) {
    const QualityStats s = compute_stats(m, threads);
    EXPECT_EQ(s.alpha_worst, aw);
    EXPECT_EQ(s.worst_tet, worst);
    EXPECT_LT(s.alpha_worst, 0.0);  // the inverted tet
    EXPECT_EQ(s.inverted_or_flat, flat);
    EXPECT_GE(flat, 2);
    EXPECT_EQ(s.mean_ratio_worst, mrw);
    EXPECT_EQ(s.radius_ratio_worst, rrw);
    EXPECT_LT(s.radius_ratio_worst, 1e-12);  // the flat tet (flat up to rounding)
    EXPECT_EQ(s.dihedral_histogram, hist);
    EXPECT_EQ(s.dihedral_below_5, small);
    EXPECT_EQ(s.dihedral_above_175, large);
    EXPECT_NEAR(s.dihedral_min, dmin, 1e-9);
    EXPECT_NEAR(s.dihedral_max, dmax, 1e-9);
  }
}

TEST(Quality, DihedralExtremesEqualTheMinAndMaxOfTheSixAngles) {
  // dihedral_extremes computes atan2 only for the edges whose angle is
  // nearly extreme; its result must be dihedral_angles' min and max bit for
  // bit (the dihedral measure of the topology passes is built on it, and the
  // output must not depend on which of the two computed it).  Shapes: random,
  // slivers (four nearly coplanar points), needles, caps, flat and
  // degenerate tets, repeated points, tiny and huge scales, and the
  // regular tet (six equal angles: ties).
  std::mt19937_64 rng(12345);
  auto check = [](const double* a, const double* b, const double* c, const double* d) {
    double dh[6], lo = 0, hi = 0;
    dihedral_angles(a, b, c, d, dh);
    dihedral_extremes(a, b, c, d, lo, hi);
    const double want_lo = *std::min_element(dh, dh + 6), want_hi = *std::max_element(dh, dh + 6);
    EXPECT_EQ(std::memcmp(&lo, &want_lo, sizeof lo), 0) << lo << " vs " << want_lo;
    EXPECT_EQ(std::memcmp(&hi, &want_hi, sizeof hi), 0) << hi << " vs " << want_hi;
  };
  int n = 0;
  for (int k = 0; k < 200000; ++k) {
    double p[4][3];
    tetopt_test::shaped_tet(k, rng, p);
    check(p[0], p[1], p[2], p[3]);
    ++n;
  }
  const double r[4][3] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  check(r[0], r[1], r[2], r[3]);
  const double z[3] = {0, 0, 0};
  check(z, z, z, z);  // all four points equal: every angle 0
  EXPECT_EQ(n, 200000);
}

TEST(Report, JsonStringIsValidJsonForAnyBytes) {
  EXPECT_EQ(json_string("a\"b\\c\nd\te"), "\"a\\\"b\\\\c\\nd\\te\"");
  EXPECT_EQ(json_string(std::string("x\x01y\x7f", 4)), "\"x\\u0001y\\u007f\"");
  // Well-formed UTF-8 passes as it is; other bytes (a Latin-1 file name,
  // a truncated sequence, an overlong form, a surrogate) become U+FFFD.
  EXPECT_EQ(json_string("d\xC3\xA9j\xC3\xA0 \xE2\x82\xAC \xF0\x9F\x98\x80"), "\"d\xC3\xA9j\xC3\xA0 \xE2\x82\xAC \xF0\x9F\x98\x80\"");
  EXPECT_EQ(json_string("x\xff\xfe.mesh"), "\"x\\ufffd\\ufffd.mesh\"");
  EXPECT_EQ(json_string("a\xC3"), "\"a\\ufffd\"");
  EXPECT_EQ(json_string("\xC0\xAF"), "\"\\ufffd\\ufffd\"");
  EXPECT_EQ(json_string("\xED\xA0\x80"), "\"\\ufffd\\ufffd\\ufffd\"");
}
