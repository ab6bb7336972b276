// Best-apex bounds and the "why is this tet still bad?" classification.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>

#include "tetopt/diagnose.hpp"
#include "needle_box.hpp"
#include "tetopt/conventions.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/improve.hpp"
#include "tetopt/invariants.hpp"
#include "tetopt/io.hpp"
#include "tetopt/measures.hpp"
#include "tetopt/quality.hpp"

using namespace tetopt;

namespace {

double min_dihedral(const double* a, const double* b, const double* c, const double* d) {
  double dh[6];
  dihedral_angles(a, b, c, d, dh);
  return *std::min_element(dh, dh + 6);
}
double max_dihedral(const double* a, const double* b, const double* c, const double* d) {
  double dh[6];
  dihedral_angles(a, b, c, d, dh);
  return *std::max_element(dh, dh + 6);
}

// A rigid motion plus uniform scale applied to a point.
void transform(const double* p, double* out) {
  const double s = 3.7, ca = std::cos(0.7), sa = std::sin(0.7), cb = std::cos(-1.3), sb = std::sin(-1.3);
  const double x1 = ca * p[0] - sa * p[1], y1 = sa * p[0] + ca * p[1], z1 = p[2];
  const double y2 = cb * y1 - sb * z1, z2 = sb * y1 + cb * z1;
  out[0] = s * x1 + 10.5;
  out[1] = s * y2 - 4.25;
  out[2] = s * z2 + 1e3;
}

TetMesh single_tet(const double pts[4][3]) {
  TetMesh m;
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 3; ++k) m.xyz.push_back(pts[i][k]);
  m.tets = {0, 1, 2, 3};
  m.tet_ref = {1};
  m.vert_ref.assign(4, 0);
  EXPECT_GT(tet_signed_volume(pts[0], pts[1], pts[2], pts[3]), 0);
  EXPECT_TRUE(build_topology(m).ok());
  return m;
}

// The highest alpha over `samples` random apexes in the box [lo, hi] on
// triangle (a, b, c); and over apexes near the triangle (within its longest
// edge, where the best ones are), also inside the box.
double sampled_best(const double* a, const double* b, const double* c, const double lo[3], const double hi[3],
                    int samples, uint32_t seed) {
  std::mt19937 g(seed);
  std::uniform_real_distribution<double> u(0, 1);
  double best = 0;
  const double cx = (a[0] + b[0] + c[0]) / 3, cy = (a[1] + b[1] + c[1]) / 3, cz = (a[2] + b[2] + c[2]) / 3;
  for (int i = 0; i < samples; ++i) {
    double x[3];
    for (int k = 0; k < 3; ++k) {
      if (i % 2) {
        x[k] = lo[k] + (hi[k] - lo[k]) * u(g);
      } else {
        const double cen = k == 0 ? cx : k == 1 ? cy : cz;
        x[k] = std::clamp(cen + 2.0 * (u(g) - 0.5), lo[k], hi[k]);
      }
    }
    best = std::max(best, std::fabs(alpha(a, b, c, x)));
  }
  return best;
}

}  // namespace

TEST(Diagnose, EquilateralTriangleGivesRegularTet) {
  const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0.5, std::sqrt(3.0) / 2, 0};
  const ApexResult r = best_apex(a, b, c);
  EXPECT_NEAR(r.value, 1.0, 1e-9);
  // The regular tet's apex: above the centroid at height sqrt(2/3).
  EXPECT_NEAR(r.apex[0], 0.5, 1e-4);
  EXPECT_NEAR(r.apex[1], std::sqrt(3.0) / 6, 1e-4);
  EXPECT_NEAR(r.apex[2], std::sqrt(2.0 / 3.0), 1e-4);
  EXPECT_NEAR(alpha(a, b, c, r.apex), r.value, 1e-12);
  const double regular = std::acos(1.0 / 3.0) * 180.0 / M_PI;  // 70.5288 deg
  EXPECT_NEAR(best_apex(a, b, c, ApexObjective::MinDihedral).value, regular, 1e-5);
  EXPECT_NEAR(best_apex(a, b, c, ApexObjective::MaxDihedral).value, regular, 1e-5);
}

TEST(Diagnose, InvariantUnderRigidMotionAndScale) {
  const double p[3][3] = {{0, 0, 0}, {1, 0, 0}, {0.2, 0.45, 0}};
  double q[3][3];
  for (int i = 0; i < 3; ++i) transform(p[i], q[i]);
  for (ApexObjective o : {ApexObjective::Alpha, ApexObjective::MinDihedral, ApexObjective::MaxDihedral}) {
    const double v0 = best_apex(p[0], p[1], p[2], o).value;
    const double v1 = best_apex(q[0], q[1], q[2], o).value;
    EXPECT_NEAR(v0, v1, o == ApexObjective::Alpha ? 1e-7 : 1e-4);
    // Reversed orientation: the apex goes to the other side, same value.
    EXPECT_NEAR(best_apex(q[0], q[2], q[1], o).value, v1, o == ApexObjective::Alpha ? 1e-7 : 1e-4);
  }
}

TEST(Diagnose, ApexIsAchievedAndBeatsDenseRandomSampling) {
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 12; ++trial) {
    const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0};
    // From near-equilateral to needles and caps.
    const double c[3] = {0.5 + 0.9 * u(rng), (trial % 3 == 0 ? 0.03 : 0.5) * (1.05 + u(rng)), 0};
    const ApexResult r = best_apex(a, b, c);
    ASSERT_GT(r.apex[2], 0);
    EXPECT_NEAR(alpha(a, b, c, r.apex), r.value, 1e-12) << "trial " << trial;
    EXPECT_GE(r.value + 1e-15, cheap_apex_value(a, b, c)) << "trial " << trial;
    EXPECT_LE(r.value, 1.0 + 1e-12);
    const ApexResult rmin = best_apex(a, b, c, ApexObjective::MinDihedral);
    const ApexResult rmax = best_apex(a, b, c, ApexObjective::MaxDihedral);
    EXPECT_NEAR(min_dihedral(a, b, c, rmin.apex), rmin.value, 1e-9);
    EXPECT_NEAR(max_dihedral(a, b, c, rmax.apex), rmax.value, 1e-9);
    double sampled = 0, sampled_min = 0, sampled_max = 180;
    for (int s = 0; s < 20000; ++s) {
      const double d[3] = {0.5 + 1.5 * u(rng), 0.3 + 1.5 * u(rng), 0.75 * (1 + u(rng)) + 1e-6};
      sampled = std::max(sampled, alpha(a, b, c, d));
      sampled_min = std::max(sampled_min, min_dihedral(a, b, c, d));
      sampled_max = std::min(sampled_max, max_dihedral(a, b, c, d));
    }
    EXPECT_GE(r.value, sampled - 1e-12) << "trial " << trial << " c = " << c[0] << " " << c[1];
    EXPECT_GE(rmin.value, sampled_min - 1e-9) << "trial " << trial;
    EXPECT_LE(rmax.value, sampled_max + 1e-9) << "trial " << trial;
    // And sampling gets close (the optimum is not an isolated spike).
    EXPECT_LT(r.value - sampled, 0.05) << "trial " << trial;
  }
}

TEST(Diagnose, DegenerateTriangle) {
  const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {2, 0, 0};
  EXPECT_EQ(best_apex(a, b, c).value, 0.0);
  EXPECT_EQ(best_apex(a, a, b).value, 0.0);
  EXPECT_EQ(best_apex(a, b, c, ApexObjective::MaxDihedral).value, 180.0);
}

TEST(Diagnose, NeedleTriangleLocksItsTet) {
  // Face (0,1,2) is a needle: no apex can make its tet good.
  const double p[4][3] = {{0, 0, 0}, {1, 0, 0}, {0.5, 0.01, 0}, {0.5, 0.3, 0.5}};
  TetMesh m = single_tet(p);
  const Diagnosis d = diagnose(m, {0.3, true});
  ASSERT_EQ(d.poor.size(), 1u);
  EXPECT_EQ(d.poor[0].cls, TetClass::LockedByTriangle);
  EXPECT_EQ(d.count[static_cast<int>(TetClass::LockedByTriangle)], 1);
  EXPECT_LT(d.poor[0].best_alpha, 0.3);
  EXPECT_GE(d.poor[0].best_alpha, d.poor[0].alpha - 1e-9);  // the tet itself is an apex
  // No looser than the needle's own bound (a single tet's faces are all on
  // the boundary, so a wedge of two of them may bound it tighter still).
  const double needle = best_apex(p[0], p[1], p[2]).value;
  EXPECT_LE(d.poor[0].best_alpha, needle + 1e-9);
  if (std::isnan(d.poor[0].wedge_alpha)) {
    EXPECT_EQ(d.poor[0].face, 3);  // the face opposite vertex 3
  }
  // The mesh-wide bound is that bound.
  EXPECT_EQ(d.bound.triangles, 4);
  EXPECT_NEAR(d.bound.alpha, d.poor[0].best_alpha, 1e-9);
  EXPECT_EQ(d.bound.alpha_tet, 0);
  const std::string text = format_diagnosis(d);
  EXPECT_NE(text.find("locked by its boundary triangle"), std::string::npos) << text;
  EXPECT_NE(text.find("best possible"), std::string::npos) << text;
}

// A flat sliver over a unit square: every face is a near-right-isoceles
// triangle (best alpha well above 0.3), all four vertices constrained.
// Alone, its faces are all on the boundary and meet at its tiny dihedral
// angles: the only tet any mesh can put on them is as flat (the wedge bound,
// issue 27), so it is locked by its triangles.  Wrapped in four caps (one
// good tet on each face, apexes outward) its faces are interior: nothing
// bounds it, but no vertex can move, so it is locked by its neighbours.
TEST(Diagnose, SliverWithGoodFacesIsLockedByNeighbours) {
  const double h = 0.05;
  const double p[4][3] = {{0, 0, 0}, {1, 1, 0}, {1, 0, h}, {0, 1, h}};
  double q[4][3];
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 3; ++k) q[i][k] = p[i][k];
  if (tet_signed_volume(p[0], p[1], p[2], p[3]) < 0)
    for (int k = 0; k < 3; ++k) std::swap(q[2][k], q[3][k]);
  {
    TetMesh alone = single_tet(q);
    ASSERT_LT(tet_alpha(alone, 0), 0.3);
    const Diagnosis d = diagnose(alone, {0.3, true});
    ASSERT_EQ(d.poor.size(), 1u);
    EXPECT_EQ(d.poor[0].cls, TetClass::LockedByTriangle);
    EXPECT_TRUE(!std::isnan(d.poor[0].wedge_alpha) || d.poor[0].wedged);
    EXPECT_LT(d.bound.alpha, 0.3);
    EXPECT_GE(d.bound.alpha, tet_alpha(alone, 0) - 1e-9);
    // mesh_bound alone: its faces' own bounds are above 0.3, the wedges at
    // their edges leave only the tet itself.
    const MeshBound mb = mesh_bound(alone);
    EXPECT_NEAR(mb.alpha, tet_alpha(alone, 0), 1e-6);
    EXPECT_EQ(mb.below_at_least[2], 1);
  }
  // The wrapped sliver.
  TetMesh m;
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 3; ++k) m.xyz.push_back(q[i][k]);
  m.tets = {0, 1, 2, 3};
  for (int f = 0; f < 4; ++f) {
    const int32_t a = kFaceVertex[f][0], b = kFaceVertex[f][1], c = kFaceVertex[f][2];
    double cen[3], n[3];
    const double* A = q[a]; const double* B = q[b]; const double* C = q[c];
    for (int k = 0; k < 3; ++k) cen[k] = (A[k] + B[k] + C[k]) / 3;
    const double u[3] = {B[0] - A[0], B[1] - A[1], B[2] - A[2]}, v[3] = {C[0] - A[0], C[1] - A[1], C[2] - A[2]};
    n[0] = u[1] * v[2] - u[2] * v[1]; n[1] = u[2] * v[0] - u[0] * v[2]; n[2] = u[0] * v[1] - u[1] * v[0];
    const double ln = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    // Outward: away from the vertex opposite the face.
    const double* o = q[f];
    const double side = (o[0] - cen[0]) * n[0] + (o[1] - cen[1]) * n[1] + (o[2] - cen[2]) * n[2];
    const double sg = side > 0 ? -1.0 : 1.0;
    for (int k = 0; k < 3; ++k) m.xyz.push_back(cen[k] + sg * 0.8 * n[k] / ln);
    const int32_t apex = 4 + f;
    int32_t t[4] = {a, b, c, apex};
    if (tet_signed_volume(m.point(t[0]), m.point(t[1]), m.point(t[2]), m.point(t[3])) < 0) std::swap(t[0], t[1]);
    m.tets.insert(m.tets.end(), t, t + 4);
  }
  m.tet_ref.assign(5, 1);
  m.vert_ref.assign(8, 0);
  ASSERT_TRUE(build_topology(m).ok());
  ASSERT_TRUE(validate(m, ValidateLevel::Full).ok());
  const Diagnosis d = diagnose(m, {0.3, true});
  const PoorTet* sliver = nullptr;
  for (const PoorTet& x : d.poor)
    if (x.tet == 0) sliver = &x;
  ASSERT_NE(sliver, nullptr);
  EXPECT_EQ(sliver->kind, 4);
  EXPECT_EQ(sliver->constrained_faces, 0);
  EXPECT_EQ(sliver->cls, TetClass::LockedByNeighbours);
  EXPECT_TRUE(std::isnan(sliver->wedge_alpha));
  // The sliver as a region of its own: its faces are interfaces, kept by
  // every method, and on the sliver's side each edge's next kept face is
  // another face of the sliver, at its tiny dihedral angle.  The wedges on
  // that side leave only the sliver itself (nineteenth session: wedges walk
  // to the next constrained face, interfaces included).
  TetMesh r = m;
  r.tet_ref[0] = 2;
  ASSERT_TRUE(build_topology(r).ok());
  const MeshBound rb = mesh_bound(r);
  EXPECT_NEAR(rb.alpha, tet_alpha(r, 0), 1e-6);
  EXPECT_LT(rb.alpha, 0.3);
  const Diagnosis rd = diagnose(r, {0.3, true});
  const PoorTet* rs = nullptr;
  for (const PoorTet& x : rd.poor)
    if (x.tet == 0) rs = &x;
  ASSERT_NE(rs, nullptr);
  EXPECT_EQ(rs->constrained_faces, 4);
  EXPECT_EQ(rs->cls, TetClass::LockedByTriangle);
  EXPECT_TRUE(rs->wedged);
  EXPECT_NE(format_diagnosis(rd).find("sharp boundary edges around it"), std::string::npos);
}

TEST(Diagnose, JitteredBoxInteriorTetsAreImprovable) {
  BoxMeshOptions o;
  o.nx = o.ny = o.nz = 5;
  o.jitter = 0.45;
  o.seed = 3;
  TetMesh m = make_box_mesh(o);
  ASSERT_TRUE(build_topology(m).ok());
  const Diagnosis d = diagnose(m, {0.4, true});
  EXPECT_EQ(d.count[0] + d.count[1] + d.count[2] + d.count[3], m.nt());
  int64_t interior_poor = 0;
  for (const PoorTet& p : d.poor) {
    EXPECT_LT(p.alpha, 0.4);
    if (p.kind == 0) {
      ++interior_poor;
      EXPECT_EQ(p.cls, TetClass::Improvable) << "tet " << p.tet;
    }
    EXPECT_EQ(d.tet_class[p.tet], static_cast<uint8_t>(p.cls));
  }
  EXPECT_GT(interior_poor, 0);
  // Boundary triangles are right-isoceles halves of unit squares: each
  // one's best apex is far above 0.4, so nothing is locked by one.  Two of
  // them meeting at a box edge share its 90 degrees (pair_best_alpha): the
  // bound is that pair's, 0.6859, below a triangle's own 0.7968 (the
  // twenty-eighth session; it was the triangle's own before).
  EXPECT_EQ(d.count[static_cast<int>(TetClass::LockedByTriangle)], 0);
  const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0};
  EXPECT_LT(d.bound.alpha, best_apex(a, b, c).value - 0.05);
  EXPECT_TRUE(d.bound.alpha_pair);
  EXPECT_GE(d.bound.alpha, compute_stats(m).alpha_worst);
  EXPECT_EQ(d.bound.triangles, 6 * 25 * 2);
  // Poor tets are listed worst first.
  for (size_t i = 1; i < d.poor.size(); ++i) EXPECT_LE(d.poor[i - 1].alpha, d.poor[i].alpha);
  const std::string js = diagnosis_to_json(d, 3);
  EXPECT_NE(js.find("\"improvable\": " + std::to_string(d.count[3])), std::string::npos);
}

TEST(Diagnose, TetValueMapCarriesSurvivors) {
  TetMesh m = make_box_mesh({});
  ASSERT_TRUE(build_topology(m).ok());
  std::vector<double> vals(m.nt());
  for (int32_t t = 0; t < m.nt(); ++t) vals[t] = t * 0.5;
  const TetValueMap map(m, vals);
  TetMesh m2 = m;
  std::swap(m2.tets[0], m2.tets[1]);              // same vertex set, reordered: survives
  m2.tets[4 * 5 + 0] = m2.tets[4 * 6 + 3];        // tet 5 now has another vertex set
  const std::vector<double> got = map.lookup(m2);
  EXPECT_EQ(got[0], 0.0);
  EXPECT_EQ(got[7], 3.5);
  EXPECT_TRUE(std::isnan(got[5]));
  EXPECT_EQ(map.matched(m2), m.nt() - 1);
}

TEST(Diagnose, TireBoundAgreesWithTheReferee) {
  const std::string path = TETOPT_SOURCE_DIR "/../shared/meshes/tire/tire.vtk";
  TetMesh m;
  if (!read_mesh(path, m).ok()) GTEST_SKIP() << "no " << path;
  ASSERT_TRUE(build_topology(m).ok());
  const MeshBound b = mesh_bound(m);
  // ../shared/tools/bound.py tire.vtk prints alpha_upper_bound=0.1992 (4
  // digits), each triangle's own bound.  The tightest triangle is a needle
  // on the tire's face x = -3 whose best apex lies 2.5 away, beyond the
  // other face x = -5: the tet on it stays between the two (a wall 2
  // thick), which lowers the bound to 0.1969.  Random apexes between the
  // faces near the triangle may not beat it and come close to it.
  EXPECT_LT(b.alpha, 0.1992 - 1e-3);
  EXPECT_GT(b.alpha, 0.1992 - 5e-3);
  EXPECT_NEAR(b.alpha_wall_d, 2.0, 1e-9);
  const double* fp[3];
  const int32_t* v = m.tet(b.alpha_tet);
  for (int k = 0; k < 3; ++k) fp[k] = m.point(v[kFaceVertex[b.alpha_face][k]]);
  for (int k = 0; k < 3; ++k) ASSERT_EQ(fp[k][0], -3.0);
  const double lo[3] = {-5, b.alpha_location[1] - 3, b.alpha_location[2] - 3};
  const double hi[3] = {-3, b.alpha_location[1] + 3, b.alpha_location[2] + 3};
  const double s = sampled_best(fp[0], fp[1], fp[2], lo, hi, 200000, 5u);
  EXPECT_GE(b.alpha + 1e-4, s);
  EXPECT_GT(s, b.alpha - 2e-3);
  EXPECT_LT(b.seconds, 2.0);
}

// Issue 26: the bound of every other per-tet measure (minimum sine, scaled
// Jacobian, radius ratio, mean ratio, equivolume skewness).  For each, the
// best apex is achieved (the measure at the apex returned is the value), is
// at least the cheap candidates' value and at least the best of dense random
// sampling (near-equilateral triangles, needles and caps), and sampling
// gets close to it.
TEST(Diagnose, EveryMeasureBestApexIsAchievedAndBeatsSampling) {
  std::mt19937_64 rng(777);
  std::uniform_real_distribution<double> u(-1, 1);
  struct M {
    ApexObjective obj;
    double (*f)(const double*, const double*, const double*, const double*);
    bool lower;  // public value minimised
  };
  const M ms[] = {{ApexObjective::SineMin, sine_min, false},
                  {ApexObjective::ScaledJacobian, scaled_jacobian, false},
                  {ApexObjective::RadiusRatio, radius_ratio, false},
                  {ApexObjective::MeanRatio, mean_ratio, false},
                  {ApexObjective::Skewness, equivolume_skewness, true}};
  for (int trial = 0; trial < 6; ++trial) {
    const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0};
    const double c[3] = {0.5 + 0.9 * u(rng), (trial % 3 == 0 ? 0.03 : 0.5) * (1.05 + u(rng)), 0};
    for (const M& mm : ms) {
      SCOPED_TRACE(static_cast<int>(mm.obj));
      const ApexResult r = best_apex(a, b, c, mm.obj);
      ASSERT_GT(r.apex[2], 0);
      EXPECT_NEAR(mm.f(a, b, c, r.apex), r.value, 1e-9) << "trial " << trial;
      const double cheap = cheap_apex_value(a, b, c, mm.obj);
      double sampled = mm.lower ? 1 : 0;
      for (int s = 0; s < 20000; ++s) {
        const double d[3] = {0.5 + 1.5 * u(rng), 0.3 + 1.5 * u(rng), 0.75 * (1 + u(rng)) + 1e-6};
        const double v = mm.f(a, b, c, d);
        sampled = mm.lower ? std::min(sampled, v) : std::max(sampled, v);
      }
      if (mm.lower) {
        EXPECT_LE(r.value, cheap + 1e-12) << "trial " << trial;
        EXPECT_LE(r.value, sampled + 1e-9) << "trial " << trial;
        EXPECT_LT(sampled - r.value, 0.05) << "trial " << trial;
      } else {
        EXPECT_GE(r.value, cheap - 1e-12) << "trial " << trial;
        EXPECT_GE(r.value, sampled - 1e-9) << "trial " << trial;
        if (mm.obj == ApexObjective::SineMin) {
          // The minimum sine's maxima are narrow ridges (a min of six
          // sines), and on a flat triangle (a cap or a needle, height 0.03
          // or less) a spike at the scale of that height (an apex that close
          // makes a needle tet, whose dihedral angles are all fair): the
          // search beats sampling by up to 0.18 here, so only "at least as
          // good" is checked, also against sampling at the small scale.
          double fine = 0;
          for (int s = 0; s < 40000; ++s) {
            const double d[3] = {0.5 + 0.9 * u(rng), 0.03 * u(rng), 0.02 * (1 + u(rng)) + 1e-7};
            fine = std::max(fine, mm.f(a, b, c, d));
          }
          EXPECT_GE(r.value, fine - 1e-9) << "trial " << trial;
        } else {
          EXPECT_LT(r.value - sampled, 0.05) << "trial " << trial;
        }
      }
    }
  }
  // The regular tet's measures on the equilateral triangle.
  const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0.5, std::sqrt(3.0) / 2, 0};
  EXPECT_NEAR(best_apex(a, b, c, ApexObjective::MeanRatio).value, 1.0, 1e-6);
  EXPECT_NEAR(best_apex(a, b, c, ApexObjective::RadiusRatio).value, 1.0, 1e-6);
  EXPECT_NEAR(best_apex(a, b, c, ApexObjective::Skewness).value, 0.0, 1e-6);
}

// The mesh-wide bound of every measure is a bound: the mesh itself keeps its
// triangles, so its worst value of each measure is no better than the bound
// (a jittered box, and the needle box whose needle triangles hold its worst
// tets); without all_measures only alpha and the dihedral angles are given.
TEST(Diagnose, EveryMeasureBoundHoldsForTheMeshItself) {
  for (int which = 0; which < 2; ++which) {
    SCOPED_TRACE(which);
    TetMesh m = make_box_mesh({.nx = 5, .ny = 5, .nz = 3, .jitter = which ? 0.45 : 0.3, .seed = 9});
    if (which) {  // a needle on the bottom face: a vertex moved almost onto its neighbour
      for (int32_t v = 0; v < m.nv(); ++v) {
        double* p = m.point(v);
        if (p[2] == 0.0 && p[0] > 1.5 && p[0] < 2.5 && p[1] > 1.5 && p[1] < 2.5) p[0] = 2.999;
      }
    }
    ASSERT_TRUE(build_topology(m).ok());
    if (!nonpositive_tets(m).empty()) GTEST_SKIP() << "the needle inverted a tet";
    const MeshBound partial = mesh_bound(m, 1, false);
    EXPECT_TRUE(std::isnan(partial.measure[static_cast<size_t>(Measure::ScaledJacobian)]));
    EXPECT_EQ(partial.measure[static_cast<size_t>(Measure::Alpha)], partial.alpha);
    const MeshBound mb = mesh_bound(m, 2, true);
    EXPECT_EQ(mb.alpha, partial.alpha);
    const QualityStats s = compute_stats(m, 1, true);
    for (int k = 0; k < kTetMeasureCount; ++k) {
      const Measure mk = static_cast<Measure>(k);
      const double bound = mb.measure[static_cast<size_t>(k)];
      ASSERT_FALSE(std::isnan(bound)) << kMeasures[k].key;
      EXPECT_GE(oriented(mk, bound), oriented(mk, s.measures.m[static_cast<size_t>(k)].worst) - 1e-12)
          << kMeasures[k].key;
    }
  }
}

// Issue 27, item 2: two boundary faces of one tet meeting at a sharp edge.
// The tet on one of them, in any mesh keeping both, has its apex inside the
// wedge they make (the tet is the only one at their common edge), so its
// alpha is bounded by wedge_best_alpha, far below the triangle's own bound
// when the wedge is sharp.  Checked against dense random sampling of apexes
// inside the wedge (none may beat it), against the tet itself (it is in the
// wedge: the bound is at least its alpha), and against the unconstrained
// bound (never above it).
TEST(Diagnose, SharpWedgeBoundsTheTetOnItsFaces) {
  std::mt19937_64 rng(2027);
  std::uniform_real_distribution<double> u(0, 1);
  for (double deg : {4.0, 10.0, 25.0, 60.0, 100.0}) {
    SCOPED_TRACE(deg);
    const double th = deg * M_PI / 180;
    const double p[3] = {0, 0, 0}, q[3] = {1, 0, 0}, r[3] = {0.45, 0.9, 0};
    const double s[3] = {0.55, 0.9 * std::cos(th), 0.9 * std::sin(th)};
    const double w = wedge_best_alpha(p, q, r, s);
    const double free_bound = best_apex(p, q, r).value;
    EXPECT_GE(w + 1e-12, alpha(p, q, r, s)) << "the tet itself is in the wedge";
    EXPECT_LE(w, free_bound + 1e-9);
    // Random apexes in the wedge: angle phi in (0, th) about the x axis,
    // any x, distance up to 2.
    double sampled = 0;
    for (int k = 0; k < 40000; ++k) {
      const double phi = th * u(rng), rho = 2 * u(rng) + 1e-6, x = -0.5 + 2 * u(rng);
      const double d[3] = {x, rho * std::cos(phi), rho * std::sin(phi)};
      sampled = std::max(sampled, alpha(p, q, r, d));
    }
    EXPECT_GE(w, sampled - 1e-9);
    EXPECT_LT(w - sampled, 0.05);  // and sampling gets close
    if (deg <= 10) {
      EXPECT_LT(w, 0.5 * free_bound) << "a sharp wedge must tighten the bound";
    }
  }
}

// The diagnosis uses it: a one-tet mesh whose two faces meet at 3 degrees
// (every face on the boundary) is locked at its own alpha, and the mesh
// bound says so (the triangles alone allowed more).
TEST(Diagnose, WedgeLockInTheDiagnosisAndTheBound) {
  const double th = 3 * M_PI / 180;
  TetMesh m;
  m.xyz = {0, 0, 0, 1, 0, 0, 0.5, 1, 0, 0.5, std::cos(th), std::sin(th)};
  m.tets = {0, 1, 2, 3};
  m.tet_ref = {1};
  if (tet_signed_volume(m.point(0), m.point(1), m.point(2), m.point(3)) < 0) std::swap(m.tets[2], m.tets[3]);
  ASSERT_TRUE(build_topology(m).ok());
  DiagnoseOptions o;
  o.threshold = 0.3;
  o.mesh_bound = true;
  const Diagnosis d = diagnose(m, o);
  ASSERT_EQ(d.poor.size(), 1u);
  const PoorTet& p = d.poor[0];
  EXPECT_EQ(p.cls, TetClass::LockedByTriangle);
  ASSERT_TRUE(!std::isnan(p.wedge_alpha) || p.wedged);
  EXPECT_NEAR(p.best_alpha, p.alpha, 1e-6) << "the only mesh keeping all four faces is this tet";
  EXPECT_NEAR(d.bound.alpha, p.alpha, 1e-6);
  EXPECT_FALSE(d.bound.alpha_pair) << "a wedge's bound, not a pair's";
  // mesh_bound alone sees the wedges at every face's sharp edges (nineteenth
  // session), where it used to give the faces' own bound, far above.
  const MeshBound plain = mesh_bound(m);
  EXPECT_NEAR(plain.alpha, p.alpha, 1e-6);
  double own = 1;
  for (int f = 0; f < 4; ++f) {
    const int32_t* v = m.tet(0);
    own = std::min(own, best_apex(m.point(v[kFaceVertex[f][0]]), m.point(v[kFaceVertex[f][1]]),
                                  m.point(v[kFaceVertex[f][2]])).value);
  }
  EXPECT_GT(own, plain.alpha + 1e-4);
  const std::string text = format_diagnosis(d);
  EXPECT_TRUE(text.find("meeting at") != std::string::npos ||
              text.find("sharp boundary edges around it") != std::string::npos)
      << text;
}

// Two kept triangles meeting at a sharp edge share its angle: the tets on
// them are one tet, or two whose dihedral angles there add up to at most
// the angle between the triangles (diagnose.cpp, pair_best_alpha).  On
// jittered boxes (their edges and corners are sharp, and a jittered corner
// tet often has two kept faces) the bound must hold for the box itself and
// for what improve() with insertion makes of it (the same kept triangles),
// and a pair must be what holds it in some of them, else nothing is shown.
TEST(Diagnose, PairBoundHoldsForTheMeshAndItsImprovement) {
  int by_pair = 0;
  for (uint64_t seed = 1; seed <= 6; ++seed) {
    SCOPED_TRACE(seed);
    TetMesh m = make_box_mesh({.nx = 3, .ny = 3, .nz = 3, .jitter = 0.45, .seed = seed});
    ASSERT_TRUE(build_topology(m).ok());
    if (!nonpositive_tets(m).empty()) continue;
    const MeshBound b = mesh_bound(m);
    by_pair += b.alpha_pair;
    const double before = compute_stats(m, 1).alpha_worst;
    EXPECT_GE(b.alpha, before - 1e-12);
    ImproveOptions o;
    o.mode = ImproveMode::Best;
    o.allow_insert = o.allow_remove = true;
    ImproveReport r;
    ASSERT_TRUE(improve(m, o, r).ok());
    ASSERT_TRUE(r.invariants_ok) << r.invariant_message;
    const double after = compute_stats(m, 1).alpha_worst;
    EXPECT_GE(b.alpha, after - 1e-9) << "pair " << b.alpha_pair << ", before " << before;
    std::printf("seed %d: worst %.4f -> %.4f, bound %.4f%s\n", static_cast<int>(seed), before, after, b.alpha,
                b.alpha_pair ? " (a pair)" : "");
  }
  EXPECT_GT(by_pair, 0) << "no box's bound came from a pair: nothing shown";
}

// The count bound (MeshBound::below_at_least).  A needle box: every bad
// triangle lies on the plane z = 0, so no two can be faces of one tet (each
// one's far vertex lies on the other's plane) and the bound is the number of
// bottom triangles whose best apex is below each threshold, counted here
// from best_apex directly.  It holds for the mesh itself and for the mesh
// after improve(), which keeps those triangles.
TEST(Diagnose, CountBoundOnCoplanarNeedles) {
  int moved = 0;
  TetMesh m = tetopt_test::needle_box(6, 2, 3, &moved);
  ASSERT_GT(moved, 2);
  ASSERT_TRUE(build_topology(m).ok());
  std::array<int64_t, 3> expect{0, 0, 0};
  for (int32_t t = 0; t < m.nt(); ++t)
    for (int f = 0; f < 4; ++f) {
      if (m.adj[4 * static_cast<size_t>(t) + f] >= 0) continue;
      const int32_t* v = m.tet(t);
      const double *a = m.point(v[kFaceVertex[f][0]]), *b = m.point(v[kFaceVertex[f][1]]),
                   *c = m.point(v[kFaceVertex[f][2]]);
      if (a[2] != 0 || b[2] != 0 || c[2] != 0) continue;
      const double best = best_apex(a, b, c).value;
      for (size_t k = 0; k < 3; ++k) expect[k] += best < kCountThresholds[k] - 1e-4 ? 1 : 0;
    }
  ASSERT_GT(expect[2], 0);  // the needles are bad at 0.3
  const MeshBound mb = mesh_bound(m, 2, false);
  for (size_t k = 0; k < 3; ++k) {
    SCOPED_TRACE(k);
    EXPECT_EQ(mb.below_at_least[k], expect[k]);
    int64_t below = 0;
    for (int32_t t = 0; t < m.nt(); ++t) below += tet_alpha(m, t) < kCountThresholds[k];
    EXPECT_LE(mb.below_at_least[k], below);
  }
  ImproveOptions o;
  o.mode = ImproveMode::Best;
  ImproveReport r;
  ASSERT_TRUE(improve(m, o, r).ok());
  for (size_t k = 0; k < 3; ++k) {
    int64_t below = 0;
    for (int32_t t = 0; t < m.nt(); ++t) below += tet_alpha(m, t) < kCountThresholds[k];
    EXPECT_LE(mb.below_at_least[k], below) << k;
  }
  const Diagnosis d = diagnose(m, {0.3, true});
  EXPECT_EQ(d.bound.below_at_least, mb.below_at_least);
  EXPECT_NE(format_diagnosis(d).find("and at least " + std::to_string(expect[0]) + " / "), std::string::npos);
  EXPECT_NE(diagnosis_to_json(d).find("\"tets_below_at_least\": {\"0.1\": " + std::to_string(expect[0])),
            std::string::npos);
}

// A lone needle tet: its four faces are all bad and pairwise faces of one
// tet (each far vertex on the side of the tet), so one tet may carry them
// all: the bound is 1, the tet itself.  Counting each bad triangle apart
// would claim 4, more than this very mesh has.
TEST(Diagnose, CountBoundLetsOneTetCarryItsBadFaces) {
  const double p[4][3] = {{0, 0, 0}, {1, 0, 0}, {0.5, 0.004, 0}, {0.5, 0.002, 0.003}};
  TetMesh m = single_tet(p);
  const MeshBound mb = mesh_bound(m, 1, false);
  ASSERT_LT(mb.alpha, 0.1);
  EXPECT_EQ(mb.below_at_least, (std::array<int64_t, 3>{1, 1, 1}));
}

// alpha_ceiling never falls below the best apex's alpha (it is a ceiling),
// on random triangles from fair to needles and caps, and is within a small
// factor of it on needles (where the count floor relies on it).
TEST(Diagnose, AlphaCeilingIsAboveTheBestApex) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  int tight = 0;
  for (int i = 0; i < 300; ++i) {
    double a[3], b[3], c[3];
    for (int k = 0; k < 3; ++k) { a[k] = u(rng); b[k] = u(rng); c[k] = u(rng); }
    if (i % 3 == 1)  // a needle: c near the segment ab
      for (int k = 0; k < 3; ++k) c[k] = 0.4 * a[k] + 0.6 * b[k] + 0.01 * u(rng);
    if (i % 3 == 2)  // a cap: c near the midpoint, slightly off the line
      for (int k = 0; k < 3; ++k) c[k] = 0.5 * (a[k] + b[k]) + 0.02 * u(rng);
    const double best = best_apex(a, b, c).value;
    const double ceil = alpha_ceiling(a, b, c);
    EXPECT_GE(ceil, best - 1e-12) << i;
    if (best < 0.1 && ceil < 4 * best) ++tight;
  }
  EXPECT_GT(tight, 50);  // needles and caps: the ceiling decides them
}

// Walls one tet thick (issue 27, item 2): the tet standing on a kept
// triangle of one face of a thin slab has its apex inside the slab (beyond
// the other face, the segment from the triangle's centroid to the apex
// would cross a kept triangle of that face, inside the tet), so its alpha is
// bounded by the best apex no higher than the slab: side_bound sees the
// facing wall.
namespace {

// The kept (constrained) faces of m whose three vertices lie at height z,
// each with its tet, local face and points.
struct KeptFace {
  int32_t t;
  int f;
  const double* p[3];
};
std::vector<KeptFace> kept_faces_at(const TetMesh& m, double z) {
  std::vector<KeptFace> out;
  for (int32_t t = 0; t < m.nt(); ++t)
    for (int f = 0; f < 4; ++f) {
      if (!(m.face_mask[t] & (1u << f))) continue;
      const int32_t* v = m.tet(t);
      KeptFace k{t, f, {m.point(v[kFaceVertex[f][0]]), m.point(v[kFaceVertex[f][1]]), m.point(v[kFaceVertex[f][2]])}};
      if (k.p[0][2] == z && k.p[1][2] == z && k.p[2][2] == z) out.push_back(k);
    }
  return out;
}

// make_box_mesh's nx x ny x 1 slab, flattened to thickness d.
TetMesh thin_slab(int n, double d) {
  BoxMeshOptions bo;
  bo.nx = bo.ny = n;
  bo.nz = 1;
  TetMesh m = make_box_mesh(bo);
  for (int32_t v = 0; v < m.nv(); ++v) m.xyz[3 * static_cast<size_t>(v) + 2] *= d;
  EXPECT_TRUE(build_topology(m).ok());
  return m;
}

// improve with insertion and removal on a copy of m, which keeps its kept
// triangles: the result must stay under dg's bound and over its count
// floor.  worst and below (at kCountThresholds) are the result's.
void improve_within_bound(const TetMesh& m, const Diagnosis& dg, double& worst, int64_t below[3]) {
  TetMesh w = m;
  ImproveOptions o;
  o.mode = ImproveMode::Best;
  o.allow_insert = o.allow_remove = true;
  ImproveReport r;
  ASSERT_TRUE(improve(w, o, r).ok());
  for (int32_t t = 0; t < w.nt(); ++t) {
    const double q = tet_alpha(w, t);
    worst = std::min(worst, q);
    for (size_t k = 0; k < 3; ++k) below[k] += q < kCountThresholds[k];
  }
  EXPECT_LE(worst, dg.bound.alpha + 1e-9);
  for (size_t k = 0; k < 3; ++k) EXPECT_LE(dg.bound.below_at_least[k], below[k]) << k;
}

}  // namespace

TEST(Diagnose, ThinSlabCapsTheApex) {
  const double d = 0.15;
  TetMesh m = thin_slab(6, d);
  const MeshBound old_like = [&] {
    // Each kept triangle's own bound (no walls): what the bound was.
    MeshBound b;
    b.alpha = 1;
    for (int32_t t = 0; t < m.nt(); ++t)
      for (int f = 0; f < 4; ++f)
        if (m.face_mask[t] & (1u << f)) {
          const int32_t* v = m.tet(t);
          b.alpha = std::min(b.alpha, best_apex(m.point(v[kFaceVertex[f][0]]), m.point(v[kFaceVertex[f][1]]),
                                                m.point(v[kFaceVertex[f][2]])).value);
        }
    return b;
  }();
  int checked = 0;
  double worst_side = 1;
  for (const KeptFace& k : kept_faces_at(m, 0)) {  // the bottom face
    const int32_t t = k.t;
    const int f = k.f;
    const double *a = k.p[0], *b = k.p[1], *c = k.p[2];
      const SideBound sb = side_bound(m, 4 * t + f);
      worst_side = std::min(worst_side, sb.alpha);
      if (checked++ % 9) continue;  // sample a few of them
      SCOPED_TRACE(t);
      EXPECT_TRUE(sb.walled);
      EXPECT_NEAR(sb.wall_distance, d, 1e-12);
      const double own = best_apex(a, b, c).value;
      EXPECT_LT(sb.alpha, own - 0.1) << "the wall caps the apex";
      // Every apex inside the slab is a point of the domain: none may beat
      // the bound, and the best of them comes close to it.
      const double lo[3] = {0, 0, 0}, hi[3] = {6, 6, d};
      const double s = sampled_best(a, b, c, lo, hi, 40000, 7u + static_cast<uint32_t>(t));
      EXPECT_GE(sb.alpha + 1e-4, s);
      EXPECT_GT(s, 0.97 * sb.alpha);
      EXPECT_GE(sb.alpha + 1e-12, tet_alpha(m, t)) << "the tet there now";
    }
  ASSERT_GT(checked, 30);
  // The diagnosis says why, and the mesh-wide bound and the count floor see it.
  const Diagnosis dg = diagnose(m, {0.3, true});
  EXPECT_LE(dg.bound.alpha, worst_side + 1e-9);
  EXPECT_LT(dg.bound.alpha, old_like.alpha - 0.05);
  EXPECT_FALSE(std::isnan(dg.bound.alpha_wall_d));
  ASSERT_FALSE(dg.poor.empty());
  EXPECT_TRUE(dg.poor[0].walled);
  EXPECT_NE(format_diagnosis(dg).find("and the wall facing it, d = 0.15"), std::string::npos) << format_diagnosis(dg);
  // The 72 bottom and 72 top triangles are bad at 0.3 (not at 0.2), and no
  // two of them can be faces of one tet (those sharing an edge are
  // coplanar), so each needs its own; the side triangles' own bound (0.308)
  // is above 0.3.  Without the walls the floor was 0.
  EXPECT_EQ(dg.bound.below_at_least[2], 144);
  EXPECT_EQ(dg.bound.below_at_least[1], 0);
  // With the walls off (DiagnoseOptions::walls, mesh_bound's walls: what
  // tetopt improve's summary computes) the bound is the triangles' own, or
  // a pair's at the slab's sharp edges (pair_best_alpha: 0.2984 against the
  // triangles' 0.3083), far above the walled one; the floor at 0.3 is 0
  // again; nothing is said to be walled.
  DiagnoseOptions no_walls;
  no_walls.walls = false;
  const Diagnosis open_dg = diagnose(m, no_walls);
  EXPECT_LE(open_dg.bound.alpha, old_like.alpha + 1e-4);
  EXPECT_GT(open_dg.bound.alpha, dg.bound.alpha + 0.05);
  EXPECT_GE(open_dg.bound.alpha, compute_stats(m).alpha_worst);
  EXPECT_NEAR(mesh_bound(m, 1, false, false).alpha, open_dg.bound.alpha, 1e-12);
  EXPECT_EQ(open_dg.bound.below_at_least[2], 0);
  EXPECT_TRUE(std::isnan(open_dg.bound.alpha_wall_d));
  for (const PoorTet& p : open_dg.poor) EXPECT_FALSE(p.walled);
  // improve with insertion and removal keeps the triangles: it stays under
  // the bound and over the count floor.
  double worst = 1;
  int64_t below[3] = {0, 0, 0};
  improve_within_bound(m, dg, worst, below);
  std::printf("slab d=%g: own %.4f capped %.4f diag %.4f improve worst %.4f floor %lld/%lld/%lld below %lld/%lld/%lld\n",
              d, old_like.alpha, worst_side, dg.bound.alpha, worst, (long long)dg.bound.below_at_least[0],
              (long long)dg.bound.below_at_least[1], (long long)dg.bound.below_at_least[2], (long long)below[0],
              (long long)below[1], (long long)below[2]);
}

// A thin wall inside a box, as a region interface: make_box_mesh's 4 x 4 x 3
// box with its middle layer squeezed to 0.15 (z in [1.5, 1.65]) and made
// region 2.  The tets of the wall stand on interface triangles (kept) whose
// other face is 0.15 away: capped from inside the wall, not from outside (the
// box's faces are 1.5 away, beyond one longest edge).
TEST(Diagnose, ThinWallInsideABoxCapsOnlyItsInside) {
  BoxMeshOptions bo;
  bo.nx = bo.ny = 4;
  bo.nz = 3;
  TetMesh m = make_box_mesh(bo);
  const double zmap[4] = {0, 1.5, 1.65, 3.2};
  for (int32_t v = 0; v < m.nv(); ++v) {
    double& z = m.xyz[3 * static_cast<size_t>(v) + 2];
    z = zmap[static_cast<int>(std::lround(z))];
  }
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = m.tet(t);
    double cz = 0;
    for (int k = 0; k < 4; ++k) cz += m.point(v[k])[2] / 4;
    m.tet_ref[t] = cz > 1.5 && cz < 1.65 ? 2 : 1;
  }
  ASSERT_TRUE(build_topology(m).ok());
  int inside = 0, outside = 0;
  double inside_min = 1;
  for (const KeptFace& k : kept_faces_at(m, 1.5)) {  // the wall's lower face
    const int32_t t = k.t;
    const int f = k.f;
    const double *a = k.p[0], *b = k.p[1], *c = k.p[2];
      const SideBound sb = side_bound(m, 4 * t + f);
      const double own = best_apex(a, b, c).value;
      if (m.tet_ref[t] == 2) {
        ++inside;
        EXPECT_TRUE(sb.walled);
        EXPECT_NEAR(sb.wall_distance, 0.15, 1e-12);
        EXPECT_LT(sb.alpha, own - 0.1);
        inside_min = std::min(inside_min, sb.alpha);
        const double lo[3] = {0, 0, 1.5}, hi[3] = {4, 4, 1.65};
        const double s = sampled_best(a, b, c, lo, hi, 40000, 11u + static_cast<uint32_t>(t));
        EXPECT_GE(sb.alpha + 1e-4, s);
        EXPECT_GT(s, 0.97 * sb.alpha);
      } else {
        ++outside;
        EXPECT_FALSE(sb.walled);
        EXPECT_NEAR(sb.alpha, own, 1e-9);
      }
    }
  ASSERT_EQ(inside, 32);
  ASSERT_EQ(outside, 32);
  const Diagnosis dg = diagnose(m, {0.3, true});
  EXPECT_NEAR(dg.bound.alpha, inside_min, 1e-9);
  EXPECT_NEAR(dg.bound.alpha_wall_d, 0.15, 1e-12);
  // The wall's 32 + 32 interface triangles are bad at 0.3 from inside and
  // no two can be faces of one tet: 64 tets below 0.3 in every mesh (the
  // triangles' own bound, 0.3083 on each side, gave none).
  EXPECT_EQ(dg.bound.below_at_least[2], 64);
  double worst = 1;
  int64_t below[3] = {0, 0, 0};
  improve_within_bound(m, dg, worst, below);
  std::printf("wall 0.15: capped %.4f improve worst %.4f floor %lld/%lld/%lld below %lld/%lld/%lld\n", dg.bound.alpha,
              worst, (long long)dg.bound.below_at_least[0], (long long)dg.bound.below_at_least[1],
              (long long)dg.bound.below_at_least[2], (long long)below[0], (long long)below[1], (long long)below[2]);
}

// The slab of ThinSlabCapsTheApex, one layer of kept vertices: the tet on a
// bottom triangle has its apex at a vertex of the top face in every mesh
// that adds no vertex inside the slab, and the top vertices stand above the
// bottom ones, never above a triangle's middle where the continuous bound
// puts its apex.  SideBound::vertex_alpha is the best of those apexes
// (brute force over every top vertex agrees), below the continuous bound and
// at least the tet there now; the diagnosis reports it (tw_A: 0.0770
// against a continuous 0.0957, the worst tet at 0.0735).
TEST(Diagnose, ThinSlabVertexApexBound) {
  const double d = 0.15;
  TetMesh m = thin_slab(6, d);
  int checked = 0;
  double lowest = 1;
  for (const KeptFace& k : kept_faces_at(m, 0)) {  // the bottom face
    const int32_t t = k.t;
    const int f = k.f;
    const double *a = k.p[0], *b = k.p[1], *c = k.p[2];
      SCOPED_TRACE(t);
      const SideBound sb = side_bound(m, 4 * t + f);
      ASSERT_TRUE(sb.walled);
      ASSERT_FALSE(std::isnan(sb.vertex_alpha));
      double brute = 0;
      int32_t at = -1;
      for (int32_t u = 0; u < m.nv(); ++u)
        if (m.point(u)[2] == d) {
          const double q = std::fabs(alpha(a, b, c, m.point(u)));
          if (q > brute) { brute = q; at = u; }
        }
      EXPECT_NEAR(sb.vertex_alpha, brute, 1e-12);
      EXPECT_NEAR(std::fabs(alpha(a, b, c, m.point(sb.vertex_apex))), brute, 1e-12) << at;
      EXPECT_LT(sb.vertex_alpha, sb.alpha - 0.02) << "no top vertex stands where the continuous bound's apex does";
      EXPECT_GE(sb.vertex_alpha + 1e-12, tet_alpha(m, t));
      lowest = std::min(lowest, sb.vertex_alpha);
      ++checked;
    }
  ASSERT_EQ(checked, 72);
  const Diagnosis dg = diagnose(m, {0.3, true});
  ASSERT_FALSE(std::isnan(dg.vertex_bound));
  EXPECT_LT(dg.vertex_bound, dg.bound.alpha - 0.02);
  EXPECT_GE(dg.vertex_bound + 1e-12, lowest);
  // Every tet of this mesh stands on a bottom or top triangle with its apex
  // at a vertex, so the worst is at most the vertex bound.
  double worst = 1;
  for (int32_t t = 0; t < m.nt(); ++t) worst = std::min(worst, tet_alpha(m, t));
  EXPECT_LE(worst, dg.vertex_bound + 1e-12);
  const std::string text = format_diagnosis(dg);
  EXPECT_NE(text.find("with no new vertex inside the walls"), std::string::npos) << text;
  EXPECT_NE(text.find("with no new vertex inside the wall "), std::string::npos) << text;
  // A free vertex among the side's (here: one marked free) leaves the
  // side without a vertex bound: the wall is not one layer of kept vertices.
  TetMesh s = m;
  int32_t t0 = -1;
  int f0 = -1;
  for (int32_t t = 0; t < s.nt() && t0 < 0; ++t)
    for (int f = 0; f < 4 && t0 < 0; ++f)
      if ((s.face_mask[t] & (1u << f)) && !std::isnan(side_bound(s, 4 * t + f).vertex_alpha)) t0 = t, f0 = f;
  ASSERT_GE(t0, 0);
  s.vert_constrained[static_cast<size_t>(s.tet(t0)[f0])] = 0;
  const SideBound free_sb = side_bound(s, 4 * t0 + f0);
  EXPECT_TRUE(free_sb.walled);
  EXPECT_TRUE(std::isnan(free_sb.vertex_alpha));
  EXPECT_EQ(free_sb.vertex_apex, -1);
}

// improve with insertion runs its rounds once more when the worst alpha ends
// below 0.9 of what the boundary allows.  On the slab of
// ThinSlabVertexApexBound the rounds end at a side's vertex bound, far
// below the triangles' own bound (what improve's cheap mesh-wide bound
// sees): the walled sides of the tets near the worst (near_worst_cap in
// improve.cpp) say so, and the rounds do not run again.
TEST(Diagnose, ImproveRunsNoRoundsAgainWhereAWalledSideCapsTheWorst) {
  TetMesh m = thin_slab(6, 0.15);
  const Diagnosis dg = diagnose(m, {0.3, true});
  ASSERT_FALSE(std::isnan(dg.vertex_bound));
  TetMesh w = m;
  ImproveOptions o;
  o.mode = ImproveMode::Best;
  o.allow_insert = o.allow_remove = true;
  ImproveReport r;
  std::vector<std::string> lines;
  const LogFn log = [&](LogLevel, const std::string& s) { lines.push_back(s); };
  ASSERT_TRUE(improve(w, o, r, log).ok());
  double worst = 1;
  for (int32_t t = 0; t < w.nt(); ++t) worst = std::min(worst, tet_alpha(w, t));
  // The cheap bound alone would have asked for the rounds once more.
  ASSERT_LT(worst, 0.9 * mesh_bound(w, 1, false, false).alpha);
  double cap = NAN;
  bool again = false;
  const std::string said = "walled sides near the worst allow alpha ";
  for (const std::string& s : lines) {
    if (s.rfind(said, 0) == 0) cap = std::stod(s.substr(said.size()));
    again = again || s.rfind("rounds again", 0) == 0;
  }
  ASSERT_FALSE(std::isnan(cap));
  EXPECT_FALSE(again);
  EXPECT_LT(worst, cap + 1e-6) << "a bound";  // the log prints 6 decimals
  EXPECT_GE(worst, 0.9 * cap);
  EXPECT_GE(cap + 1e-6, dg.vertex_bound);
}


// The diagnosis runs its searches in parallel (one task per side, ranges
// of 16 poor tets); what it says must not depend on the thread count, bit
// for bit: the same classes, bounds, faces and counts as one thread gives.
// A thin slab (walled sides), a needle box (triangle shapes shared by many
// faces) and a raw box whose tets all have boundary faces.
TEST(Diagnose, SameForEveryThreadCount) {
  std::vector<TetMesh> meshes;
  meshes.push_back(thin_slab(6, 0.15));
  int moved = 0;
  meshes.push_back(tetopt_test::needle_box(8, 2, 5, &moved));
  for (TetMesh& m : meshes) ASSERT_TRUE(build_topology(m).ok());
  auto same = [](double x, double y) { return std::memcmp(&x, &y, sizeof x) == 0; };
  int64_t searched = 0, walled = 0;
  for (const TetMesh& m : meshes) {
    for (const bool walls : {true, false}) {
      DiagnoseOptions o;
      o.threshold = 0.3;
      o.walls = walls;
      o.threads = 1;
      const Diagnosis d1 = diagnose(m, o);
      o.threads = 4;
      const Diagnosis d4 = diagnose(m, o);
      ASSERT_EQ(d1.poor.size(), d4.poor.size());
      EXPECT_EQ(d1.faces_searched, d4.faces_searched);
      for (int k = 0; k < 4; ++k) EXPECT_EQ(d1.count[k], d4.count[k]);
      EXPECT_TRUE(same(d1.bound.alpha, d4.bound.alpha));
      EXPECT_TRUE(same(d1.vertex_bound, d4.vertex_bound));
      for (size_t i = 0; i < d1.poor.size(); ++i) {
        const PoorTet &a = d1.poor[i], &b = d4.poor[i];
        SCOPED_TRACE(a.tet);
        EXPECT_EQ(a.tet, b.tet);
        EXPECT_EQ(a.cls, b.cls);
        EXPECT_EQ(a.face, b.face);
        EXPECT_EQ(a.constrained_faces, b.constrained_faces);
        EXPECT_EQ(a.wedged, b.wedged);
        EXPECT_EQ(a.walled, b.walled);
        EXPECT_EQ(a.wedge_face, b.wedge_face);
        EXPECT_TRUE(same(a.best_alpha, b.best_alpha));
        EXPECT_TRUE(same(a.wedge_alpha, b.wedge_alpha));
        EXPECT_TRUE(same(a.wall_d, b.wall_d));
        EXPECT_TRUE(same(a.vertex_alpha, b.vertex_alpha));
        walled += a.walled;
      }
      EXPECT_EQ(format_diagnosis(d1), format_diagnosis(d4));
      searched += d1.faces_searched;
    }
  }
  EXPECT_GT(searched, 32) << "few searches: the parallel path went untested";
  EXPECT_GT(walled, 0) << "no walled side was met";
}
