// What the HTML report's 3D view draws (view3d.hpp): the boundary surface,
// its display-only decimation, the poor-tet sets, the page's view section.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>

#include "tetopt/conventions.hpp"
#include "tetopt/diagnose.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/html_report.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/view3d.hpp"

#include "needle_box.hpp"

using namespace tetopt;

namespace {

TetMesh box(int n, double jitter, int regions, bool listed_tris = true) {
  BoxMeshOptions o;
  o.nx = o.ny = o.nz = n;
  o.jitter = jitter;
  o.regions = regions;
  o.seed = 11;
  TetMesh m = make_box_mesh(o);
  if (!listed_tris) {
    m.tris.clear();
    m.tri_ref.clear();
  }
  EXPECT_TRUE(build_topology(m).ok());
  return m;
}

// Volume enclosed by the surface's triangles (divergence theorem): positive
// when every triangle faces outward.
double enclosed_volume(const ViewSurface& s) {
  double v = 0;
  for (size_t t = 0; t < s.tris.size(); t += 3) {
    double p[3][3];
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) p[i][k] = s.xyz[3 * static_cast<size_t>(s.tris[t + i]) + k] + s.origin[k];
    v += p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1]) - p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0]) +
         p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0]);
  }
  return v / 6;
}

}  // namespace

TEST(View3d, Base64MatchesRfc4648Vectors) {
  const std::string in = "foobar";
  const char* want[] = {"", "Zg==", "Zm8=", "Zm9v", "Zm9vYg==", "Zm9vYmE=", "Zm9vYmFy"};
  for (size_t n = 0; n <= in.size(); ++n) EXPECT_EQ(base64(in.data(), n), want[n]) << n;
  const unsigned char high[] = {0xff, 0xfe, 0x00};
  EXPECT_EQ(base64(high, 3), "//4A");
}

TEST(View3d, SurfaceIsTheOutwardBoundary) {
  const TetMesh m = box(4, 0.3, 1);
  const ViewSurface s = view_surface(m);
  EXPECT_EQ(s.triangles_full, 6 * 4 * 4 * 2);  // 6 sides of 4x4 cells, 2 triangles each
  EXPECT_FALSE(s.decimated);
  EXPECT_EQ(s.tris.size(), 3 * static_cast<size_t>(s.triangles_full));
  // Every boundary vertex once (jitter moves only interior vertices).
  EXPECT_EQ(s.xyz.size() / 3, static_cast<size_t>(6 * 5 * 5 - 12 * 5 + 8));
  EXPECT_NEAR(enclosed_volume(s), 64.0, 1e-4);  // the box [0,4]^3, outward
  EXPECT_NEAR(s.origin[0], 2.0, 1e-12);
  EXPECT_NEAR(s.bbox_diagonal, 4 * std::sqrt(3.0), 1e-9);
  // Listed triangles (ref 1): one patch.
  EXPECT_TRUE(s.by_patch);
  ASSERT_EQ(s.group_ref.size(), 1u);
  EXPECT_EQ(s.group_ref[0], 1);
  EXPECT_EQ(s.group_count[0], s.triangles_full);
}

TEST(View3d, SurfaceGroupsByRegionWithoutListedTriangles) {
  const TetMesh m = box(4, 0.0, 2, /*listed_tris=*/false);
  const ViewSurface s = view_surface(m);
  EXPECT_FALSE(s.by_patch);
  // The boundary and, once, the interface x = 2 between the regions.
  EXPECT_EQ(s.triangles_full, 6 * 4 * 4 * 2 + 4 * 4 * 2);
  ASSERT_EQ(s.group_ref.size(), 2u);
  // Region 1 is x < 2: its boundary triangles and the interface (taken from
  // the smaller ref) are those whose centroid has x <= 2; every triangle of
  // region 2 has a corner with x > 2.
  int64_t left = 0, interface = 0;
  for (size_t t = 0; t < s.tris.size(); t += 3) {
    double x[3];
    for (int i = 0; i < 3; ++i) x[i] = s.xyz[3 * static_cast<size_t>(s.tris[t + i])] + s.origin[0];
    left += (x[0] + x[1] + x[2]) / 3 <= 2 + 1e-9;
    interface += std::fabs(x[0] - 2) < 1e-9 && std::fabs(x[1] - 2) < 1e-9 && std::fabs(x[2] - 2) < 1e-9;
  }
  EXPECT_EQ(interface, 4 * 4 * 2);
  EXPECT_EQ(s.group_ref[0], 1);
  EXPECT_EQ(s.group_ref[1], 2);
  EXPECT_EQ(s.group_start[0], 0);
  EXPECT_EQ(s.group_count[0], left);
  EXPECT_EQ(s.group_start[1], left);
  EXPECT_EQ(s.group_count[0] + s.group_count[1], s.triangles_full);
  // The triangles of group 1 really lie at x <= 2.
  for (int32_t t = 0; t < s.group_count[0]; ++t)
    for (int i = 0; i < 3; ++i) EXPECT_LE(s.xyz[3 * static_cast<size_t>(s.tris[3 * t + i])] + s.origin[0], 2.0 + 1e-6);
}

TEST(View3d, DecimatesForDisplayOnlyAboveTheBudget) {
  const TetMesh m = box(12, 0.3, 1);  // 1728 boundary triangles
  const size_t budget = 400;
  const ViewSurface s = view_surface(m, budget);
  EXPECT_EQ(s.triangles_full, 6 * 12 * 12 * 2);
  EXPECT_TRUE(s.decimated);
  const size_t k = s.tris.size() / 3;
  EXPECT_LE(k, budget);
  EXPECT_GE(k, budget / 2);  // the grid is refined toward the budget
  const size_t nv = s.xyz.size() / 3;
  std::set<std::array<int32_t, 3>> seen;
  for (size_t t = 0; t < s.tris.size(); t += 3) {
    std::array<int32_t, 3> v{s.tris[t], s.tris[t + 1], s.tris[t + 2]};
    for (int32_t x : v) ASSERT_LT(static_cast<size_t>(x), nv);
    EXPECT_TRUE(v[0] != v[1] && v[1] != v[2] && v[0] != v[2]);
    std::sort(v.begin(), v.end());
    EXPECT_TRUE(seen.insert(v).second) << "repeated triangle";
  }
  // Still the box, roughly, and still outward.
  EXPECT_NEAR(enclosed_volume(s), 12.0 * 12 * 12, 0.15 * 12 * 12 * 12);
  // The same mesh within the budget is drawn whole.
  EXPECT_FALSE(view_surface(m, 5000).decimated);
}

TEST(View3d, PoorTetsAreTheWorstBelowTheThreshold) {
  const TetMesh m = box(6, 0.42, 1);
  const double gamma = 0.3;
  std::vector<std::pair<double, int32_t>> below;
  for (int32_t t = 0; t < m.nt(); ++t)
    if (const double a = tet_alpha(m, t); a < gamma) below.push_back({a, t});
  std::sort(below.begin(), below.end());
  ASSERT_GT(below.size(), 10u);
  double origin[3];
  view_origin(m, origin);
  const ViewTets all = view_poor_tets(m, gamma, 1000000, origin, nullptr, 2);
  EXPECT_EQ(all.below, static_cast<int64_t>(below.size()));
  ASSERT_EQ(all.ids.size(), below.size());
  for (size_t i = 0; i < below.size(); ++i) {
    EXPECT_EQ(all.ids[i], below[i].second);
    EXPECT_FLOAT_EQ(all.alpha[i], static_cast<float>(below[i].first));
    EXPECT_EQ(all.kind[i], m.tet_kind[static_cast<size_t>(below[i].second)]);
  }
  // Corners: the tet's own vertices, relative to the origin.
  for (size_t i = 0; i < all.ids.size(); ++i)
    for (int j = 0; j < 4; ++j) {
      const double* p = m.point(m.tet(all.ids[i])[j]);
      const int32_t v = all.tets[4 * i + static_cast<size_t>(j)];
      for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(all.xyz[3 * static_cast<size_t>(v) + k], static_cast<float>(p[k] - origin[k]));
    }
  // A cap keeps the worst; an id map renumbers.
  std::vector<int32_t> map(static_cast<size_t>(m.nt()));
  for (int32_t t = 0; t < m.nt(); ++t) map[static_cast<size_t>(t)] = 1000 + t;
  const ViewTets few = view_poor_tets(m, gamma, 5, origin, &map);
  EXPECT_EQ(few.below, all.below);
  ASSERT_EQ(few.ids.size(), 5u);
  for (size_t i = 0; i < 5; ++i) EXPECT_EQ(few.ids[i], 1000 + below[i].second);
  EXPECT_LE(few.xyz.size(), 3u * 20);
}

TEST(View3d, DiagnosedSetFollowsTheDiagnosis) {
  const TetMesh m = box(6, 0.42, 2);
  DiagnoseOptions o;
  o.threshold = 0.4;
  const Diagnosis d = diagnose(m, o);
  ASSERT_FALSE(d.poor.empty());
  double origin[3];
  view_origin(m, origin);
  const ViewTets v = view_diagnosed_tets(m, d, d.poor.size(), origin);
  ASSERT_EQ(v.ids.size(), d.poor.size());
  for (size_t i = 0; i < d.poor.size(); ++i) {
    EXPECT_EQ(v.ids[i], d.poor[i].tet);
    EXPECT_EQ(v.cls[i], static_cast<uint8_t>(d.poor[i].cls));
    EXPECT_EQ(v.cap_face[i], d.poor[i].cls == TetClass::LockedByTriangle ? d.poor[i].face : -1);
  }
}

TEST(View3d, CappingTrianglesAreTheLockingFaces) {
  // Needle triangles on the bottom face lock the tets standing on them.
  TetMesh m = tetopt_test::needle_box(5, 3, 7);
  ASSERT_TRUE(build_topology(m).ok());
  const Diagnosis d = diagnose(m, {});
  ASSERT_GT(d.count[static_cast<int>(TetClass::LockedByTriangle)], 0);
  double origin[3];
  view_origin(m, origin);
  const ViewTets v = view_diagnosed_tets(m, d, d.poor.size(), origin);
  int caps = 0;
  for (size_t i = 0; i < v.ids.size(); ++i) {
    if (v.cap_face[i] < 0) continue;
    ++caps;
    const int32_t t = v.ids[i];
    const int f = v.cap_face[i];
    // A constrained face of its tet, on the bottom (z = 0), whose best apex
    // stays below the threshold, as the diagnosis says.
    EXPECT_TRUE(m.face_mask[static_cast<size_t>(t)] >> f & 1);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(m.point(m.tet(t)[kFaceVertex[f][k]])[2], 0.0);
    EXPECT_LT(v.best_alpha[i], d.threshold);
    EXPECT_EQ(v.cls[i], static_cast<uint8_t>(TetClass::LockedByTriangle));
  }
  EXPECT_EQ(caps, d.count[static_cast<int>(TetClass::LockedByTriangle)]);
}

TEST(View3d, ReportCarriesTheViewAndClickableRows) {
  const TetMesh m = box(5, 0.42, 1);
  const Diagnosis d = diagnose(m, {});
  ASSERT_FALSE(d.poor.empty());
  HtmlReportInput in;
  in.before = compute_stats(m);
  in.before_hist = quality_histograms(m);
  in.diagnosis = &d;
  const std::string without = html_report(in);
  EXPECT_EQ(without.find("id=\"where\""), std::string::npos);
  in.mesh = &m;
  const std::string page = html_report(in);
  EXPECT_NE(page.find("id=\"where\""), std::string::npos);
  // The worst tet's row links to the view (0-based id, 1-based text).
  EXPECT_NE(page.find("<tr data-tet=\"" + std::to_string(d.poor[0].tet) + "\"><td>" + std::to_string(d.poor[0].tet + 1)),
            std::string::npos);
  if (page.find("id=\"tv-off\"") != std::string::npos) GTEST_SKIP() << "built with TETOPT_VIEW3D=OFF";
  EXPECT_NE(page.find("<script type=\"application/json\" id=\"tv-data\">"), std::string::npos);
  EXPECT_NE(page.find("<script type=\"text/plain\" id=\"tv-three-core\">"), std::string::npos);
  EXPECT_NE(page.find("<script type=\"module\">"), std::string::npos);
  EXPECT_NE(page.find("The view draws all " + std::to_string(6 * 5 * 5 * 2) + " constrained triangles"), std::string::npos);
  // A budget below the boundary's size: the page says it decimated.
  in.view_surface_budget = 100;
  EXPECT_NE(html_report(in).find("id=\"tv-decimated\""), std::string::npos);
}
