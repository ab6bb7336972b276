// The measures table (measures.hpp): values on hand-computed tets and faces,
// against independent formulas, invariances, signs on inverted tets, the
// statistics' determinism, and the CLI's JSON.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "detail/tet_kernels.hpp"
#include "tet_shapes.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/io.hpp"
#include "tetopt/measures.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/report.hpp"

using namespace tetopt;

namespace {
const double R0[3] = {0, 0, 0}, R1[3] = {1, 0, 0}, R2[3] = {0.5, std::sqrt(3.0) / 2, 0},
             R3[3] = {0.5, std::sqrt(3.0) / 6, std::sqrt(2.0 / 3.0)};

double vol6(const double* a, const double* b, const double* c, const double* d) {
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]},
               w[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
  return u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0]);
}
double dist(const double* a, const double* b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

// Independent: the scaled Jacobian as "min over the 4 corners of the
// Jacobian determinant over the product of the 3 edge lengths there, times
// √2" (for a positive tet each corner's determinant is 6V).
double sj_by_corners(const double* p[4]) {
  const double j = vol6(p[0], p[1], p[2], p[3]);
  double best = INFINITY;
  for (int i = 0; i < 4; ++i) {
    double prod = 1;
    for (int k = 0; k < 4; ++k)
      if (k != i) prod *= dist(p[i], p[k]);
    best = std::min(best, j / prod);
  }
  return std::sqrt(2.0) * best;
}

// Independent: the circumcentre from the 3x3 system 2(p_k − p_0)·x =
// |p_k|² − |p_0|² by Cramer's rule, then 1 − V / (8√3/27·R³).
double skew_by_circumcentre(const double* a, const double* b, const double* c, const double* d) {
  const double* p[3] = {b, c, d};
  double M[3][3], r[3];
  for (int k = 0; k < 3; ++k) {
    double s = 0;
    for (int j = 0; j < 3; ++j) {
      M[k][j] = 2 * (p[k][j] - a[j]);
      s += p[k][j] * p[k][j] - a[j] * a[j];
    }
    r[k] = s;
  }
  auto det3 = [](double A[3][3]) {
    return A[0][0] * (A[1][1] * A[2][2] - A[1][2] * A[2][1]) - A[0][1] * (A[1][0] * A[2][2] - A[1][2] * A[2][0]) +
           A[0][2] * (A[1][0] * A[2][1] - A[1][1] * A[2][0]);
  };
  const double D = det3(M);
  double x[3];
  for (int j = 0; j < 3; ++j) {
    double A[3][3];
    std::memcpy(A, M, sizeof A);
    for (int k = 0; k < 3; ++k) A[k][j] = r[k];
    x[j] = det3(A) / D;
  }
  const double R = dist(x, a);
  const double v = vol6(a, b, c, d) / 6.0;
  return 1.0 - v / (8.0 * std::sqrt(3.0) / 27.0 * R * R * R);
}

void similarity(const double in[3], double out[3], double s, double ang, const double tr[3]) {
  const double c = std::cos(ang), sn = std::sin(ang);
  const double x = c * in[0] - sn * in[1], y = sn * in[0] + c * in[1], z = in[2];
  const double y2 = c * y - sn * z, z2 = sn * y + c * z;
  out[0] = s * x + tr[0];
  out[1] = s * y2 + tr[1];
  out[2] = s * z2 + tr[2];
}

bool same_double(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }
}  // namespace

TEST(Measures, TableIsIndexedByIdAndComplete) {
  for (int k = 0; k < kMeasureCount; ++k) {
    const MeasureInfo& mi = kMeasures[static_cast<size_t>(k)];
    EXPECT_EQ(static_cast<int>(mi.id), k);
    EXPECT_EQ(mi.per_face, k >= kTetMeasureCount);
    EXPECT_EQ(mi.tet_fn != nullptr, !mi.per_face) << mi.key;
    EXPECT_EQ(mi.face_fn != nullptr, mi.id == Measure::NonOrthogonality || mi.id == Measure::FaceSkewness);
    EXPECT_EQ(find_measure(mi.key), &mi);
    EXPECT_GT(std::strlen(mi.source), 10u) << mi.key;
    EXPECT_GT(mi.hist_bins, 0);
    EXPECT_LT(mi.hist_lo, mi.hist_hi);
    for (int t = 0; t < mi.n_thresholds; ++t) EXPECT_GT(std::strlen(mi.thresholds[t].source), 10u) << mi.key;
  }
  EXPECT_EQ(find_measure("nonsense"), nullptr);
}

TEST(Measures, RegularTet) {
  const double sine = 2.0 * std::sqrt(2.0) / 3.0, dih = std::acos(1.0 / 3.0) * 180.0 / M_PI;
  EXPECT_NEAR(alpha(R0, R1, R2, R3), 1.0, 1e-14);
  EXPECT_NEAR(sine_min(R0, R1, R2, R3), sine, 1e-14);
  EXPECT_NEAR(std::sin(dih * M_PI / 180.0), sine, 1e-15);
  EXPECT_NEAR(dihedral_min_deg(R0, R1, R2, R3), dih, 1e-10);
  EXPECT_NEAR(dihedral_max_deg(R0, R1, R2, R3), dih, 1e-10);
  EXPECT_NEAR(dih, 70.5288, 1e-4);
  EXPECT_NEAR(scaled_jacobian(R0, R1, R2, R3), 1.0, 1e-14);
  EXPECT_NEAR(radius_ratio(R0, R1, R2, R3), 1.0, 1e-13);
  EXPECT_NEAR(mean_ratio(R0, R1, R2, R3), 1.0, 1e-14);
  EXPECT_NEAR(equivolume_skewness(R0, R1, R2, R3), 0.0, 1e-13);
  // The table's ideal is the regular tet's value, and the switch and the
  // table's function pointers give the functions' own bits.
  for (int k = 0; k < kTetMeasureCount; ++k) {
    const MeasureInfo& mi = kMeasures[static_cast<size_t>(k)];
    const double v = tet_measure(mi.id, R0, R1, R2, R3);
    EXPECT_NEAR(v, mi.ideal, 1e-10) << mi.key;
    EXPECT_TRUE(same_double(v, mi.tet_fn(R0, R1, R2, R3))) << mi.key;
  }
  // The regular tet with vertices on the sphere of radius √3: V = 8/3 =
  // 8√3/27·R³, so its equivolume skewness is 0 too.
  const double a[3] = {1, 1, 1}, b[3] = {1, -1, -1}, c[3] = {-1, 1, -1}, d[3] = {-1, -1, 1};
  EXPECT_NEAR(std::fabs(vol6(a, b, c, d)) / 6.0, 8.0 / 3.0, 1e-15);
  const bool pos = vol6(a, b, c, d) > 0;
  EXPECT_NEAR(pos ? equivolume_skewness(a, b, c, d) : equivolume_skewness(b, a, c, d), 0.0, 1e-14);
}

TEST(Measures, FlatAndSliver) {
  // Exactly flat: four coplanar points.
  const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0}, f[3] = {0.3, 0.3, 0};
  EXPECT_EQ(sine_min(a, b, c, f), 0.0);
  EXPECT_EQ(scaled_jacobian(a, b, c, f), 0.0);
  EXPECT_EQ(equivolume_skewness(a, b, c, f), 1.0);
  EXPECT_EQ(mean_ratio(a, b, c, f), 0.0);
  EXPECT_EQ(radius_ratio(a, b, c, f), 0.0);
  // All points equal: no NaN anywhere.
  for (int k = 0; k < kTetMeasureCount; ++k) EXPECT_FALSE(std::isnan(tet_measure(static_cast<Measure>(k), a, a, a, a)));
  EXPECT_EQ(scaled_jacobian(a, a, a, a), 0.0);
  EXPECT_EQ(equivolume_skewness(a, a, a, a), 1.0);
  // A sliver: a square's corners, two lifted by h.  Every measure near its
  // worst end.
  for (double h : {1e-2, 1e-4, 1e-8}) {
    const double p[3] = {0, 0, 0}, q[3] = {1, 0, h}, r[3] = {1, 1, 0}, s[3] = {0, 1, h};
    const bool pos = vol6(p, q, r, s) > 0;
    const double* P[4] = {pos ? p : q, pos ? q : p, r, s};
    EXPECT_LT(sine_min(P[0], P[1], P[2], P[3]), 10 * h);
    EXPECT_GE(sine_min(P[0], P[1], P[2], P[3]), 0.0);
    EXPECT_LT(scaled_jacobian(P[0], P[1], P[2], P[3]), 10 * h);
    EXPECT_GT(equivolume_skewness(P[0], P[1], P[2], P[3]), 1 - 10 * h);
    EXPECT_LE(equivolume_skewness(P[0], P[1], P[2], P[3]), 1.0);
    EXPECT_LT(dihedral_min_deg(P[0], P[1], P[2], P[3]), 200 * h);
    EXPECT_GT(dihedral_max_deg(P[0], P[1], P[2], P[3]), 180 - 200 * h);
  }
  // A needle (one very short edge) and a cap (d near the middle of abc):
  // small sine, Jacobian, and skewness near 1.
  const double n3[3] = {1e-4, 0, 0};
  const double rr[3] = {0.5, 0.8, 0.1};
  EXPECT_LT(std::fabs(sine_min(a, n3, c, rr)), 0.2);
  const double cap[3] = {0.3, 0.3, 1e-5};
  EXPECT_LT(sine_min(a, b, c, cap), 1e-3);
  EXPECT_GT(equivolume_skewness(a, b, c, cap), 0.99);
  EXPECT_GT(dihedral_max_deg(a, b, c, cap), 179.0);
}

TEST(Measures, AgainstIndependentFormulas) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  int n = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    double P[4][3];
    for (auto& q : P)
      for (double& x : q) x = u(rng);
    if (vol6(P[0], P[1], P[2], P[3]) < 0) std::swap(P[0], P[1]);
    const double* p[4] = {P[0], P[1], P[2], P[3]};
    if (alpha(p[0], p[1], p[2], p[3]) < 0.02) continue;  // keep the independent formulas well conditioned
    ++n;
    // sine_min = min over the edges of sin(dihedral angle).
    double dh[6];
    dihedral_angles(p[0], p[1], p[2], p[3], dh);
    double smin = INFINITY;
    for (double x : dh) smin = std::min(smin, std::sin(x * M_PI / 180.0));
    EXPECT_NEAR(sine_min(p[0], p[1], p[2], p[3]), smin, 1e-9);
    EXPECT_NEAR(scaled_jacobian(p[0], p[1], p[2], p[3]), sj_by_corners(p), 1e-12);
    EXPECT_NEAR(equivolume_skewness(p[0], p[1], p[2], p[3]), skew_by_circumcentre(p[0], p[1], p[2], p[3]), 1e-9);
    EXPECT_NEAR(dihedral_min_deg(p[0], p[1], p[2], p[3]), *std::min_element(dh, dh + 6), 0.0);
    EXPECT_NEAR(dihedral_max_deg(p[0], p[1], p[2], p[3]), *std::max_element(dh, dh + 6), 0.0);
  }
  EXPECT_GT(n, 1000);
}

TEST(Measures, InvertedTetsSignedMeasures) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 200; ++trial) {
    double P[4][3];
    for (auto& q : P)
      for (double& x : q) x = u(rng);
    if (vol6(P[0], P[1], P[2], P[3]) < 0) std::swap(P[0], P[1]);
    const double *a = P[0], *b = P[1], *c = P[2], *d = P[3];
    if (alpha(a, b, c, d) < 0.05) continue;
    // (b, a, c, d) is the same tet inverted.
    EXPECT_LT(alpha(b, a, c, d), 0.0);
    EXPECT_NEAR(alpha(b, a, c, d), -alpha(a, b, c, d), 1e-14);
    EXPECT_NEAR(mean_ratio(b, a, c, d), -mean_ratio(a, b, c, d), 1e-14);
    EXPECT_NEAR(scaled_jacobian(b, a, c, d), -scaled_jacobian(a, b, c, d), 1e-14);
    EXPECT_GE(scaled_jacobian(b, a, c, d), -1.0);
    // Every sine changes sign: the minimum is minus the largest sine.
    double dh[6];
    dihedral_angles(a, b, c, d, dh);
    double smax = -INFINITY;
    for (double x : dh) smax = std::max(smax, std::sin(x * M_PI / 180.0));
    EXPECT_NEAR(sine_min(b, a, c, d), -smax, 1e-9);
    // 1 − V/V_ideal with V < 0: above 1, mirrored about 1.
    EXPECT_GT(equivolume_skewness(b, a, c, d), 1.0);
    EXPECT_NEAR(equivolume_skewness(b, a, c, d), 2.0 - equivolume_skewness(a, b, c, d), 1e-12);
    // Unsigned: the radius ratio does not see the orientation.
    EXPECT_NEAR(radius_ratio(b, a, c, d), radius_ratio(a, b, c, d), 1e-14);
    // Worse than any valid tet by the table's direction.
    for (Measure k : {Measure::Alpha, Measure::SineMin, Measure::ScaledJacobian, Measure::MeanRatio,
                      Measure::EquivolumeSkewness})
      EXPECT_TRUE(worse(k, tet_measure(k, b, a, c, d), tet_measure(k, a, b, c, d))) << measure_info(k).key;
    EXPECT_TRUE(fails(measure_info(Measure::ScaledJacobian).thresholds[0], scaled_jacobian(b, a, c, d)));
  }
}

TEST(Measures, InvariantUnderSimilarity) {
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 50; ++trial) {
    double p[5][3];
    for (auto& q : p)
      for (double& x : q) x = u(rng);
    if (vol6(p[0], p[1], p[2], p[3]) < 0) std::swap(p[0], p[1]);
    const double tr[3] = {u(rng) * 100, u(rng) * 100, u(rng) * 100};
    const double s = std::exp(3 * u(rng)), ang = 3 * u(rng);
    double q[5][3];
    for (int i = 0; i < 5; ++i) similarity(p[i], q[i], s, ang, tr);
    for (int k = 0; k < kTetMeasureCount; ++k) {
      const Measure m = static_cast<Measure>(k);
      const double v0 = tet_measure(m, p[0], p[1], p[2], p[3]), v1 = tet_measure(m, q[0], q[1], q[2], q[3]);
      EXPECT_NEAR(v1, v0, 1e-8 * std::max(1.0, std::fabs(v0))) << measure_info(m).key;
    }
    // Face (p0, p1, p2) between apexes p3 and p4 (the normal taken out of
    // p3's side whichever way the points fall).
    const bool out = vol6(p[0], p[1], p[2], p[3]) < 0;
    const double* A[2][3] = {{p[0], out ? p[1] : p[2], out ? p[2] : p[1]},
                             {q[0], out ? q[1] : q[2], out ? q[2] : q[1]}};
    for (Measure m : {Measure::NonOrthogonality, Measure::FaceSkewness}) {
      const double v0 = face_measure(m, A[0][0], A[0][1], A[0][2], p[3], p[4]);
      const double v1 = face_measure(m, A[1][0], A[1][1], A[1][2], q[3], q[4]);
      EXPECT_NEAR(v1, v0, 1e-8 * std::max(1.0, std::fabs(v0))) << measure_info(m).key;
    }
    EXPECT_NEAR(face_skewness_boundary(A[1][0], A[1][1], A[1][2], q[3]),
                face_skewness_boundary(A[0][0], A[0][1], A[0][2], p[3]), 1e-8);
  }
}

// Two tets on the face a, b, c = (0,0,0), (1,0,0), (0,1,0), whose normal
// (b−a)×(c−a) = +z points out of the owner below it.
TEST(Measures, FaceNonOrthogonalityAndSkewnessOfAHandBuiltPair) {
  const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0};
  const double cf[3] = {1.0 / 3, 1.0 / 3, 0};
  // Mirror images: the centre line is the face normal through the centroid.
  {
    const double p[3] = {0.2, 0.4, -0.7}, q[3] = {0.2, 0.4, 0.7};
    EXPECT_NEAR(face_non_orthogonality(a, b, c, p, q), 0.0, 1e-5);
    // The centre line crosses the face plane at ((a+b+c)/4 + (0.2,0.4)/4) =
    // (0.3, 0.35), not at the face centroid: skewness is not 0.
    EXPECT_GT(face_skewness(a, b, c, p, q), 0.0);
  }
  {
    const double p[3] = {1.0 / 3, 1.0 / 3, -0.5}, q[3] = {1.0 / 3, 1.0 / 3, 2.0};
    EXPECT_NEAR(face_non_orthogonality(a, b, c, p, q), 0.0, 1e-6);
    EXPECT_NEAR(face_skewness(a, b, c, p, q), 0.0, 1e-15);
    EXPECT_NEAR(face_skewness_boundary(a, b, c, p), 0.0, 1e-15);
  }
  // The neighbour's apex shifted along x.  Independently: the cell centres
  // are the centroids, so d = (q − p)/4 and the angle between d and +z is
  // atan2(|d_xy|, d_z).  The centre line meets z = 0 at X = C_own + t·d
  // with t = −C_own,z / d_z; skewness = |C_f − X| / fd with fd the larger
  // of 0.2|d| and the largest extent of the face's vertices from C_f along
  // (C_f − X) / |C_f − X|.
  for (double shift : {0.0, 0.3, 1.0, 4.0}) {
    const double p[3] = {1.0 / 3, 1.0 / 3, -1}, q[3] = {1.0 / 3 + shift, 1.0 / 3, 1};
    double co[3], cn[3], d[3];
    for (int k = 0; k < 3; ++k) {
      co[k] = (a[k] + b[k] + c[k] + p[k]) / 4;
      cn[k] = (a[k] + b[k] + c[k] + q[k]) / 4;
      d[k] = cn[k] - co[k];
    }
    const double want_angle = std::atan2(std::hypot(d[0], d[1]), d[2]) * 180.0 / M_PI;
    EXPECT_NEAR(face_non_orthogonality(a, b, c, p, q), want_angle, 1e-9) << shift;
    const double t = -co[2] / d[2];
    const double X[3] = {co[0] + t * d[0], co[1] + t * d[1], 0};
    const double sv[3] = {cf[0] - X[0], cf[1] - X[1], 0};
    const double msv = std::hypot(sv[0], sv[1]);
    double fd = 0.2 * std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (msv > 0)
      for (const double* v : {a, b, c})
        fd = std::max(fd, std::fabs(((v[0] - cf[0]) * sv[0] + (v[1] - cf[1]) * sv[1]) / msv));
    EXPECT_NEAR(face_skewness(a, b, c, p, q), msv / fd, 1e-12) << shift;
    // The same face seen from the other tet: (a, c, b) with p and q swapped.
    EXPECT_NEAR(face_non_orthogonality(a, c, b, q, p), want_angle, 1e-9);
    EXPECT_NEAR(face_skewness(a, c, b, q, p), msv / fd, 1e-12);
  }
  // shift 1: d = (1, 0, 2)/4, so 26.565°; X = (11/24, 1/3): |sv| = 1/8,
  // fd = 2/3 (vertex b), skewness 3/16.
  const double p[3] = {1.0 / 3, 1.0 / 3, -1}, q[3] = {4.0 / 3, 1.0 / 3, 1};
  EXPECT_NEAR(face_non_orthogonality(a, b, c, p, q), std::atan(0.5) * 180 / M_PI, 1e-12);
  EXPECT_NEAR(face_non_orthogonality(a, b, c, p, q), 26.565051177077990, 1e-9);
  EXPECT_NEAR(face_skewness(a, b, c, p, q), 3.0 / 16.0, 1e-14);
  // The neighbour folded over onto the owner's side: 90° or more, an error.
  const double folded[3] = {0.3, 0.3, -1.5};  // below the owner's centroid: d points into the owner
  EXPECT_GE(face_non_orthogonality(a, b, c, p, folded), 90.0);
  EXPECT_TRUE(fails(measure_info(Measure::NonOrthogonality).thresholds[1], face_non_orthogonality(a, b, c, p, folded)));
  // Boundary skewness: the in-plane offset of the centroid projection.
  // p' = (1/3 + 0.6, 1/3, -1): C_own − C_f has in-plane part (0.15, 0) and
  // normal part −0.25 (d = 0.25 along the normal); fd = max(0.4·0.25,
  // extent along x = 2/3) → 0.15 / (2/3) = 0.225.
  const double pb[3] = {1.0 / 3 + 0.6, 1.0 / 3, -1};
  EXPECT_NEAR(face_skewness_boundary(a, b, c, pb), 0.225, 1e-14);
}

namespace {
TetMesh jittered(int n, double jitter, uint64_t seed) {
  TetMesh m = make_box_mesh({.nx = n, .ny = n, .nz = n, .jitter = jitter, .seed = seed, .regions = 2});
  EXPECT_TRUE(build_topology(m).ok());
  return m;
}
}  // namespace

TEST(Measures, StatsAreThePerItemValuesAndTheSameForEveryThreadCount) {
  TetMesh m = jittered(12, 0.45, 21);  // 10368 tets: two blocks of kBlock
  ASSERT_GT(m.nt(), 8192);
  std::swap(m.tets[100 * 4], m.tets[100 * 4 + 1]);  // one inverted tet
  const MeasureStats a = compute_measure_stats(m, 1);
  for (int threads : {2, 3, 0}) {
    const MeasureStats b = compute_measure_stats(m, threads);
    EXPECT_EQ(a.interior_faces, b.interior_faces);
    EXPECT_EQ(a.boundary_faces, b.boundary_faces);
    EXPECT_TRUE(same_double(a.non_orthogonality_checkmesh_average, b.non_orthogonality_checkmesh_average));
    EXPECT_TRUE(same_double(a.skewness_interior_worst, b.skewness_interior_worst));
    EXPECT_TRUE(same_double(a.skewness_boundary_worst, b.skewness_boundary_worst));
    for (int k = 0; k < kMeasureCount; ++k) {
      const MeasureSummary &x = a.m[static_cast<size_t>(k)], &y = b.m[static_cast<size_t>(k)];
      EXPECT_EQ(x.count, y.count);
      EXPECT_TRUE(same_double(x.worst, y.worst)) << k;
      EXPECT_TRUE(same_double(x.mean, y.mean)) << k;
      EXPECT_EQ(x.worst_tet, y.worst_tet);
      EXPECT_EQ(x.worst_face, y.worst_face);
      EXPECT_EQ(x.histogram, y.histogram);
      EXPECT_EQ(x.fail, y.fail);
      EXPECT_EQ(x.band, y.band);
    }
  }
  // Against a plain loop over the per-tet functions and the faces.
  const int32_t nt = m.nt();
  for (int k = 0; k < kTetMeasureCount; ++k) {
    const MeasureInfo& mi = kMeasures[static_cast<size_t>(k)];
    const MeasureSummary& x = a.m[static_cast<size_t>(k)];
    double worst = mi.better == Better::Higher ? INFINITY : -INFINITY, sum = 0;
    int64_t f0 = 0, hist = 0;
    for (int32_t t = 0; t < nt; ++t) {
      const int32_t* v = m.tet(t);
      const double q = mi.tet_fn(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3]));
      worst = mi.better == Better::Higher ? std::min(worst, q) : std::max(worst, q);
      sum += q;
      if (mi.n_thresholds > 0) f0 += fails(mi.thresholds[0], q);
    }
    for (int64_t h : x.histogram) hist += h;
    EXPECT_EQ(x.count, nt);
    EXPECT_EQ(hist, nt);
    EXPECT_TRUE(same_double(x.worst, worst)) << mi.key << " " << x.worst << " vs " << worst;
    EXPECT_NEAR(x.mean, sum / nt, 1e-12 * std::max(1.0, std::fabs(x.mean))) << mi.key;
    if (mi.n_thresholds > 0) { EXPECT_EQ(x.fail[0], f0) << mi.key; }
    const int32_t* v = m.tet(x.worst_tet);
    EXPECT_TRUE(same_double(mi.tet_fn(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3])), x.worst));
  }
  EXPECT_GE(a[Measure::Alpha].fail[0], 1);           // the inverted tet
  EXPECT_GE(a[Measure::ScaledJacobian].fail[0], 1);
  EXPECT_GE(a[Measure::EquivolumeSkewness].fail[2], 1);
  int64_t bands = 0;
  for (int64_t x : a[Measure::EquivolumeSkewness].band) bands += x;
  EXPECT_EQ(bands, nt);
  // Faces: each interior face once, each boundary face once.
  int64_t boundary = 0;
  for (int32_t x : m.adj) boundary += x < 0;
  EXPECT_EQ(a.boundary_faces, boundary);
  EXPECT_EQ(2 * a.interior_faces + boundary, 4 * static_cast<int64_t>(nt));
  EXPECT_EQ(a[Measure::NonOrthogonality].count, a.interior_faces);
  EXPECT_EQ(a[Measure::FaceSkewness].count, a.interior_faces + a.boundary_faces);
  // The per-tet fields: face measures as the worst of the tet's faces.
  const std::vector<double> no = compute_measure_field(m, Measure::NonOrthogonality, 2);
  const std::vector<double> sk = compute_measure_field(m, Measure::FaceSkewness, 1);
  EXPECT_TRUE(same_double(*std::max_element(no.begin(), no.end()), a[Measure::NonOrthogonality].worst));
  EXPECT_TRUE(same_double(*std::max_element(sk.begin(), sk.end()), a[Measure::FaceSkewness].worst));
  EXPECT_TRUE(same_double(std::max(a.skewness_interior_worst, a.skewness_boundary_worst),
                          a[Measure::FaceSkewness].worst));
  const std::vector<double> sj = compute_measure_field(m, Measure::ScaledJacobian, 3);
  EXPECT_TRUE(same_double(*std::min_element(sj.begin(), sj.end()), a[Measure::ScaledJacobian].worst));
  // compute_stats carries them, and the existing keys agree with the table.
  const QualityStats s = compute_stats(m, 2, true);
  EXPECT_TRUE(same_double(s.measures[Measure::Alpha].worst, s.alpha_worst));
  EXPECT_TRUE(same_double(s.measures[Measure::MeanRatio].worst, s.mean_ratio_worst));
  EXPECT_TRUE(same_double(s.measures[Measure::RadiusRatio].worst, s.radius_ratio_worst));
  EXPECT_NEAR(s.measures[Measure::DihedralMin].worst, s.dihedral_min, 1e-12);
  EXPECT_NEAR(s.measures[Measure::DihedralMax].worst, s.dihedral_max, 1e-12);
  EXPECT_EQ(s.measures[Measure::DihedralMin].fail[0], s.dihedral_below_5);
  EXPECT_EQ(s.measures[Measure::DihedralMax].fail[0], s.dihedral_above_175);
  EXPECT_EQ(s.measures[Measure::Alpha].histogram,
            std::vector<int64_t>(s.alpha_histogram.begin(), s.alpha_histogram.end()));
}

TEST(Measures, KuhnBoxFacesAreKnown) {
  // The unjittered Kuhn split of cubes: every tet is the same shape
  // (dihedrals 45/60/90), and the face measures take a few known values.
  TetMesh m = jittered(3, 0.0, 1);
  const MeasureStats s = compute_measure_stats(m, 1);
  EXPECT_NEAR(s[Measure::DihedralMin].worst, 45.0, 1e-9);
  EXPECT_NEAR(s[Measure::DihedralMax].worst, 90.0, 1e-9);
  // sin 45° is the smallest sine; the scaled Jacobian of a Kuhn tet (unit
  // cube corner path) is √2·1/max(corner products) = √2/(√2·√3·1) = 1/√3.
  EXPECT_NEAR(s[Measure::SineMin].worst, std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(s[Measure::ScaledJacobian].worst, 1.0 / std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(s[Measure::ScaledJacobian].mean, 1.0 / std::sqrt(3.0), 1e-12);
  EXPECT_LT(s[Measure::NonOrthogonality].worst, 70.0);
  EXPECT_EQ(s[Measure::NonOrthogonality].fail[0], 0);
  EXPECT_GT(s.interior_faces, 0);
}

TEST(Measures, JsonCarriesTheNestedObjects) {
  TetMesh m = jittered(3, 0.3, 4);
  const QualityStats s = compute_stats(m, 1, true);
  const std::string js = stats_to_json(s, 2);
  for (const char* k : {"\"alpha_worst\"", "\"measures\": {", "\"faces\": {", "\"sine_min\": {", "\"scaled_jacobian\"",
                        "\"equivolume_skewness\"", "\"non_orthogonality\": {", "\"skewness\": {",
                        "\"checkmesh_average\"",
                        "\"bands\": {\"excellent\"", "\"fail\": {\"gt_70\"", "\"histogram\": {\"lo\""})
    EXPECT_NE(js.find(k), std::string::npos) << k;
  // Balanced braces and brackets (a cheap well-formedness check; the CLI test
  // parses it with Python).
  int depth = 0, sq = 0;
  for (char ch : js) {
    depth += ch == '{' ? 1 : ch == '}' ? -1 : 0;
    sq += ch == '[' ? 1 : ch == ']' ? -1 : 0;
    ASSERT_GE(depth, 0);
  }
  EXPECT_EQ(depth, 0);
  EXPECT_EQ(sq, 0);
  EXPECT_EQ(js.back(), '}');
  const std::string table = format_stats_table(s);
  for (const MeasureInfo& mi : kMeasures) EXPECT_NE(table.find(mi.key), std::string::npos) << mi.key;
  const std::string hist = format_histograms(s);
  EXPECT_NE(hist.find("non_orthogonality histogram"), std::string::npos);
}

TEST(Measures, CliQualityJsonHasTheNewKeys) {
  if (std::system("/usr/bin/python3 -c 'import json' > /dev/null 2>&1") != 0) GTEST_SKIP() << "no python3";
  const std::string dir = testing::TempDir();
  const std::string mesh = dir + "/measures_cli.mesh", js = dir + "/measures_cli.json";
  TetMesh m = make_box_mesh({.nx = 4, .ny = 4, .nz = 4, .jitter = 0.4, .seed = 3, .regions = 1});
  ASSERT_TRUE(write_mesh(mesh, m).ok());
  ASSERT_EQ(std::system((std::string(TETOPT_CLI) + " quality " + mesh + " --json --threads 2 > " + js).c_str()), 0);
  const std::string py =
      "import json,sys,math\n"
      "q=json.load(open(sys.argv[1]))\n"
      "ms=q['measures']; f=q['faces']\n"
      "assert set(ms)=={'alpha','sine_min','dihedral_min','dihedral_max','scaled_jacobian','radius_ratio',"
      "'mean_ratio','equivolume_skewness'}, sorted(ms)\n"
      "assert ms['alpha']['worst']==q['alpha_worst'] and abs(ms['alpha']['mean']-q['alpha_mean'])<1e-12\n"
      "assert abs(ms['dihedral_min']['worst']-q['dihedral_min'])<1e-9\n"
      "for k,v in ms.items():\n"
      "  assert v['count']==q['tets'] and sum(v['histogram']['counts'])==q['tets'], k\n"
      "  assert v['better'] in ('higher','lower') and isinstance(v['fail'],dict), k\n"
      "assert 0<ms['sine_min']['worst']<=ms['sine_min']['mean']<=2*math.sqrt(2)/3+1e-12\n"
      "assert 0<ms['scaled_jacobian']['worst']<=1 and 0<=ms['equivolume_skewness']['worst']<1\n"
      "assert sum(ms['equivolume_skewness']['bands'].values())==q['tets']\n"
      "assert f['measured'] is True and 2*f['interior']+f['boundary']==4*q['tets']\n"
      "no=f['non_orthogonality']; sk=f['skewness']\n"
      "assert 0<=no['mean']<=no['worst']<90 and 0<=no['checkmesh_average']<=no['worst']\n"
      "assert no['count']==f['interior'] and sk['count']==f['interior']+f['boundary']\n"
      "assert sk['worst']==max(sk['interior_worst'],sk['boundary_worst'])>0\n"
      "assert 'gt_70' in no['fail'] and 'gt_4' in sk['fail'] and 'diagnosis' in q\n";
  const std::string pyfile = dir + "/measures_cli.py";
  std::ofstream(pyfile) << py;
  EXPECT_EQ(std::system(("/usr/bin/python3 " + pyfile + " " + js).c_str()), 0);
}

// The guards evaluate six measures at once from shared pieces
// (detail::tet_measure_values); every value must be its standalone
// function's bit for bit, or a tet rebuilt unchanged could be refused.
// Random, sliver, needle, cap, flat, repeated-point, inverted and
// tiny/huge tets.
TEST(Measures, TetMeasureValuesAreTheStandaloneOnes) {
  std::mt19937_64 rng(77);
  auto bits = [](double x, double y) { return std::memcmp(&x, &y, sizeof x) == 0; };
  int positive = 0, degenerate = 0;
  for (int k = 0; k < 40000; ++k) {
    double p[4][3];
    tetopt_test::shaped_tet(k, rng, p);
    const double *a = p[0], *b = p[1], *c = p[2], *d = p[3];
    const detail::TetMeasureValues v = detail::tet_measure_values(a, b, c, d);
    SCOPED_TRACE(k);
    EXPECT_TRUE(bits(v.alpha, alpha(a, b, c, d)));
    EXPECT_TRUE(bits(v.mean_ratio, mean_ratio(a, b, c, d)));
    EXPECT_TRUE(bits(v.scaled_jacobian, scaled_jacobian(a, b, c, d)));
    EXPECT_TRUE(bits(v.sine_min, sine_min(a, b, c, d)));
    EXPECT_TRUE(bits(v.radius_ratio, radius_ratio(a, b, c, d)));
    EXPECT_TRUE(bits(v.equivolume_skewness, equivolume_skewness(a, b, c, d)));
    positive += v.alpha > 0;
    degenerate += v.alpha == 0;
  }
  EXPECT_GT(positive, 10000);  // both orientations and degenerate tets were met
  EXPECT_GT(degenerate, 1000);
}

// The guards decide a dihedral comparison from tet_measure_values' cosines
// where they are beyond the extreme's cosine by 1e-9 (Guard::
// set_angle_cosines), and measure the angles (atan2) only otherwise: the
// largest and smallest cosine must be those of dihedral_extremes' angles to
// far better than that, or a tet could be admitted that the angles refuse.
TEST(Measures, DihedralCosinesAreThoseOfTheExtremeAngles) {
  std::mt19937_64 rng(78);
  const double rad = std::acos(-1.0) / 180.0;
  int compared = 0;
  double worst_lo = 0, worst_hi = 0;
  for (int k = 0; k < 40000; ++k) {
    double p[4][3];
    tetopt_test::shaped_tet(k, rng, p);
    const detail::TetMeasureValues v = detail::tet_measure_values(p[0], p[1], p[2], p[3]);
    if (std::isnan(v.cos_max) || std::isnan(v.cos_min)) continue;  // the guards measure these
    double lo, hi;
    dihedral_extremes(p[0], p[1], p[2], p[3], lo, hi);
    SCOPED_TRACE(k);
    ASSERT_TRUE(std::isfinite(lo) && std::isfinite(hi));
    worst_lo = std::max(worst_lo, std::fabs(v.cos_max - std::cos(lo * rad)));
    worst_hi = std::max(worst_hi, std::fabs(v.cos_min - std::cos(hi * rad)));
    ++compared;
  }
  EXPECT_GT(compared, 20000);
  EXPECT_LT(worst_lo, 1e-11);
  EXPECT_LT(worst_hi, 1e-11);
  std::printf("dihedral cosines against the angles' over %d tets: %.3g (smallest angle), %.3g (largest)\n", compared,
              worst_lo, worst_hi);
}
