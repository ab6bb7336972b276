// TetMesh topology, classification, orientation and validation.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "tetopt/generate.hpp"
#include "tetopt/invariants.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/predicates.hpp"
#include "tetopt/quality.hpp"

using namespace tetopt;

namespace {
TetMesh two_tets() {
  // Two positive tets sharing face (0,1,2): apexes 3 above and 4 below.
  TetMesh m;
  m.xyz = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0.3, 0.3, 1, 0.3, 0.3, -1};
  m.tets = {0, 1, 2, 3, 0, 2, 1, 4};
  m.tet_ref = {1, 1};
  m.vert_ref.assign(5, 0);
  return m;
}
}  // namespace

TEST(Mesh, BoxTooLargeForIdsOrEmptyIsRefused) {
  // 1300^3 cells overflowed the int32 vertex count and reached resize()
  // negative (std::length_error, an abort in tetopt generate).
  EXPECT_THROW(make_box_mesh({.nx = 1300, .ny = 1300, .nz = 1300}), std::invalid_argument);
  EXPECT_THROW(make_box_mesh({.nx = 700, .ny = 700, .nz = 731}), std::invalid_argument);  // 2,149,140,000 tets
  EXPECT_THROW(make_box_mesh({.nx = 0, .ny = 4, .nz = 4}), std::invalid_argument);
  EXPECT_NO_THROW(make_box_mesh({.nx = 1, .ny = 1, .nz = 1}));
}

TEST(Mesh, BoxTopologyIsValid) {
  TetMesh m = make_box_mesh({.nx = 3, .ny = 4, .nz = 5});
  ASSERT_TRUE(build_topology(m).ok());
  EXPECT_EQ(m.nt(), 6 * 3 * 4 * 5);
  Status s = validate(m);
  EXPECT_TRUE(s.ok()) << s.message;
  int boundary_faces = 0;
  for (int32_t f : m.adj) boundary_faces += f < 0;
  EXPECT_EQ(boundary_faces, 4 * (3 * 4 + 4 * 5 + 3 * 5));
  EXPECT_EQ(m.ntri(), boundary_faces);
  // Interior vertices: (nx-1)(ny-1)(nz-1) unconstrained.
  int free_v = 0;
  for (uint8_t c : m.vert_constrained) free_v += !c;
  EXPECT_EQ(free_v, 2 * 3 * 4);
  // Kinds add up and all-boundary tets exist along the box surface.
  int64_t kinds[5] = {};
  for (uint8_t k : m.tet_kind) kinds[k]++;
  EXPECT_EQ(kinds[0] + kinds[1] + kinds[2] + kinds[3] + kinds[4], m.nt());
  EXPECT_GT(kinds[4], 0);
  // CSR lists every tet of each vertex exactly once.
  for (int32_t v = 0; v < m.nv(); ++v)
    for (const int32_t* t = m.star_begin(v); t != m.star_end(v); ++t) {
      const int32_t* tv = m.tet(*t);
      EXPECT_TRUE(tv[0] == v || tv[1] == v || tv[2] == v || tv[3] == v);
    }
}

TEST(Mesh, TwoRegionInterfaceIsConstrained) {
  TetMesh m = make_box_mesh({.nx = 4, .ny = 2, .nz = 2, .regions = 2});
  ASSERT_TRUE(build_topology(m).ok());
  int interface_faces = 0;
  for (int32_t t = 0; t < m.nt(); ++t)
    for (int f = 0; f < 4; ++f) {
      const int32_t n = m.adj[4 * t + f];
      if (n < 0) continue;
      if (m.tet_ref[n / 4] != m.tet_ref[t]) {
        interface_faces++;
        EXPECT_TRUE(m.face_mask[t] >> f & 1);
      } else {
        EXPECT_FALSE(m.face_mask[t] >> f & 1);
      }
    }
  EXPECT_EQ(interface_faces, 2 * 2 * 2 * 2);  // seen from both sides
  // Every vertex on the plane x = 2 is constrained, even off the box boundary.
  for (int32_t v = 0; v < m.nv(); ++v)
    if (m.point(v)[0] == 2.0) {
      EXPECT_TRUE(m.vert_constrained[v]) << v;
    }
}

TEST(Mesh, ListedInteriorTriangleIsConstrained) {
  TetMesh m = two_tets();
  m.tris = {0, 1, 2};
  m.tri_ref = {7};
  ASSERT_TRUE(build_topology(m).ok());
  int shared = 0;
  for (int32_t t = 0; t < 2; ++t)
    for (int f = 0; f < 4; ++f)
      if (m.adj[4 * t + f] >= 0) {
        shared++;
        EXPECT_TRUE(m.face_mask[t] >> f & 1);
      }
  EXPECT_EQ(shared, 2);
  // Without the listed triangle, the shared face is free.
  m.tris.clear();
  m.tri_ref.clear();
  classify(m);
  for (int32_t t = 0; t < 2; ++t)
    for (int f = 0; f < 4; ++f)
      if (m.adj[4 * t + f] >= 0) {
        EXPECT_FALSE(m.face_mask[t] >> f & 1);
      }
}

TEST(Mesh, FaceSharedByThreeTetsIsRejected) {
  TetMesh m = two_tets();
  m.xyz.insert(m.xyz.end(), {0.2, 0.2, 2.0});
  m.tets.insert(m.tets.end(), {0, 1, 2, 5});
  m.tet_ref.push_back(1);
  Status s = build_topology(m);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message.find("shared by 3"), std::string::npos) << s.message;
}

TEST(Mesh, DuplicateTetIsRejected) {
  TetMesh m = two_tets();
  m.tets.insert(m.tets.end(), {0, 1, 2, 3});
  m.tet_ref.push_back(1);
  Status s = build_topology(m);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message.find("same four vertices"), std::string::npos) << s.message;
}

TEST(Mesh, OrientationNormalisedAndInvertedReported) {
  TetMesh m = make_box_mesh({.nx = 2, .ny = 2, .nz = 2});
  const auto orig = m.tets;
  for (int32_t t = 0; t < m.nt(); ++t) std::swap(m.tets[4 * t + 0], m.tets[4 * t + 1]);
  OrientationReport r = normalize_orientation(m);
  EXPECT_TRUE(r.flipped);
  EXPECT_TRUE(m.flipped_on_read);
  EXPECT_TRUE(r.inverted.empty());
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = m.tet(t);
    EXPECT_EQ(orient3d(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3])), Sign::Positive);
  }
  // Now invert one tet: it is reported, not flipped.
  TetMesh k = make_box_mesh({.nx = 2, .ny = 2, .nz = 2});
  std::swap(k.tets[4 * 5 + 0], k.tets[4 * 5 + 1]);
  OrientationReport r2 = normalize_orientation(k);
  EXPECT_FALSE(r2.flipped);
  ASSERT_EQ(r2.inverted.size(), 1u);
  EXPECT_EQ(r2.inverted[0], 5);
  (void)orig;
}

TEST(Mesh, CheckArraysRejectsBadInput) {
  TetMesh m = two_tets();
  EXPECT_TRUE(check_arrays(m).ok());
  TetMesh a = m;
  a.xyz[4] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(check_arrays(a, "f").message.find("NaN"), std::string::npos);
  TetMesh b = m;
  b.tets[3] = 9;
  EXPECT_NE(check_arrays(b, "f").message.find("outside"), std::string::npos);
  TetMesh c = m;
  c.tets.clear();
  c.tet_ref.clear();
  EXPECT_NE(check_arrays(c, "f").message.find("no tetrahedra"), std::string::npos);
  TetMesh d = m;
  d.tets[1] = d.tets[0];
  EXPECT_NE(check_arrays(d, "f").message.find("repeats"), std::string::npos);
  // ... but where alpha would overflow, measuring is refused; 1e60 itself and a
  // mesh scaled to 1e50 are measured as at scale 1 (alpha is scale-free).
  TetMesh e = m;
  e.xyz[7] = -2e60;
  EXPECT_TRUE(check_arrays(e, "f").ok());  // a reader keeps it (convert loses no digit) ...
  EXPECT_NE(check_measurable(e, "f").message.find("f: vertex 3 has a coordinate beyond 1e60"), std::string::npos);
  TetMesh big = m, unit = m;
  for (double& x : big.xyz) x *= 0x1p166;  // about 9e49, a power of two: exact
  EXPECT_TRUE(check_measurable(big).ok());
  for (int32_t t = 0; t < 2; ++t) EXPECT_EQ(tet_alpha(big, t), tet_alpha(unit, t));
  big.xyz[0] = 1e60;
  EXPECT_TRUE(check_measurable(big).ok());
  // Tiny tets underflow instead: a mesh scaled to about 1e-50 is measured
  // as at scale 1, one scaled to 1e-80 or 1e-300 is refused, naming a tet.
  TetMesh small = m, tiny = m, tinier = m;
  for (double& x : small.xyz) x *= 0x1p-166;
  EXPECT_TRUE(check_measurable(small).ok());
  for (int32_t t = 0; t < 2; ++t) EXPECT_EQ(tet_alpha(small, t), tet_alpha(unit, t));
  for (double& x : tiny.xyz) x *= 1e-80;
  EXPECT_NE(check_measurable(tiny, "f").message.find("f: tet 1 spans less than 1e-60"), std::string::npos);
  for (double& x : tinier.xyz) x *= 1e-300;
  EXPECT_FALSE(check_measurable(tinier).ok());
  // A tet whose four vertices coincide is flat, not unmeasurable.
  TetMesh same = m;
  for (int k = 1; k < 4; ++k)
    std::copy(same.point(same.tet(0)[0]), same.point(same.tet(0)[0]) + 3, same.point(same.tet(0)[k]));
  EXPECT_TRUE(check_measurable(same).ok());
}

TEST(Mesh, ValidateCatchesBrokenAdjacencyAndInversion) {
  TetMesh m = make_box_mesh({.nx = 2, .ny = 2, .nz = 2});
  ASSERT_TRUE(build_topology(m).ok());
  ASSERT_TRUE(validate(m).ok());
  TetMesh a = m;
  for (auto& x : a.adj)
    if (x >= 0) { x = -1; break; }
  EXPECT_FALSE(validate(a).ok());
  TetMesh b = m;
  std::swap(b.tets[0], b.tets[1]);
  EXPECT_FALSE(validate(b).ok());
}

TEST(Mesh, InvariantsDetectMovedBoundaryVertexAndLostFace) {
  TetMesh m = make_box_mesh({.nx = 3, .ny = 3, .nz = 3, .jitter = 0.2, .seed = 3, .regions = 2});
  ASSERT_TRUE(build_topology(m).ok());
  const InvariantSnapshot snap = capture_invariants(m);
  EXPECT_TRUE(check_invariants(m, snap).ok());
  // Moving a free vertex a little keeps the promise.
  TetMesh ok = m;
  for (int32_t v = 0; v < ok.nv(); ++v)
    if (!ok.vert_constrained[v]) { ok.point(v)[0] += 1e-3; break; }
  EXPECT_TRUE(check_invariants(ok, snap).ok()) << check_invariants(ok, snap).message;
  // Moving a constrained vertex by one ulp breaks it.
  TetMesh bad = m;
  for (int32_t v = 0; v < bad.nv(); ++v)
    if (bad.vert_constrained[v]) { bad.point(v)[2] = std::nextafter(bad.point(v)[2], 10.0); break; }
  Status s = check_invariants(bad, snap);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message.find("moved"), std::string::npos) << s.message;
  // Changing a region ref changes interface faces and volumes.
  TetMesh bad2 = m;
  bad2.tet_ref[0] = 2 + 1 - bad2.tet_ref[0];
  classify(bad2);
  EXPECT_FALSE(check_invariants(bad2, snap).ok());
}

TEST(Mesh, FaceBetweenGmshEntitiesIsConstrained) {
  TetMesh m = two_tets();
  ASSERT_TRUE(build_topology(m).ok());
  for (int32_t t = 0; t < 2; ++t)
    for (int f = 0; f < 4; ++f)
      if (m.adj[4 * t + f] >= 0) {
        EXPECT_FALSE(m.face_mask[t] >> f & 1);
      }
  m.tet_entity = {5, 6};  // same ref, different entities
  classify(m);
  int shared = 0;
  for (int32_t t = 0; t < 2; ++t)
    for (int f = 0; f < 4; ++f)
      if (m.adj[4 * t + f] >= 0) {
        shared++;
        EXPECT_TRUE(m.face_mask[t] >> f & 1);
      }
  EXPECT_EQ(shared, 2);
}

// A tet listed with two vertices exchanged (its neighbours' order says the
// other way round) is found, named, and repaired only when asked; a folded
// tet whose vertex order agrees with its neighbours is not touched (the
// untangler's job); a consistent mesh costs one scan and changes nothing.
TEST(Mesh, InconsistentlyListedTetIsFoundAndRepairedOnlyOnRequest) {
  const BoxMeshOptions box{.nx = 3, .ny = 3, .nz = 3, .jitter = 0.2, .regions = 2};
  TetMesh ok = make_box_mesh(box);
  ASSERT_TRUE(build_topology(ok).ok());
  const auto tets0 = ok.tets;
  OrientationReport r0;
  EXPECT_TRUE(orient_consistently(ok, false, &r0).ok());
  EXPECT_TRUE(orient_consistently(ok, true, &r0).ok());
  EXPECT_EQ(ok.tets, tets0);
  EXPECT_TRUE(r0.reoriented.empty());
  const double volume0 = [&] {
    double v = 0;
    for (const auto& [ref, vol] : capture_invariants(ok).region_volume) v += vol;
    return v;
  }();

  for (const int32_t bad : {0, 17, 100}) {  // a corner tet, one inside, one on the interface side
    TetMesh m = make_box_mesh(box);
    std::swap(m.tets[4 * static_cast<size_t>(bad) + 1], m.tets[4 * static_cast<size_t>(bad) + 3]);
    OrientationReport r = normalize_orientation(m);
    ASSERT_EQ(r.inverted, std::vector<int32_t>{bad});
    ASSERT_TRUE(build_topology(m).ok());
    const auto listed = m.tets;
    Status s = orient_consistently(m, false, &r);
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(s.code, ErrorCode::InvalidMesh);
    EXPECT_NE(s.message.find("(tet " + std::to_string(bad + 1) + ","), std::string::npos) << s.message;
    EXPECT_EQ(m.tets, listed);  // check only: nothing changed
    ASSERT_TRUE(orient_consistently(m, true, &r).ok());
    EXPECT_EQ(r.reoriented, std::vector<int32_t>{bad});
    EXPECT_TRUE(r.inverted.empty());
    EXPECT_EQ(r.negative, 0);
    EXPECT_TRUE(validate(m).ok());
    double volume = 0;
    for (const auto& [ref, vol] : capture_invariants(m).region_volume) volume += vol;
    EXPECT_NEAR(volume, volume0, 1e-12 * volume0);
    EXPECT_TRUE(orient_consistently(m, false, &r).ok());  // consistent now
  }

  // Folded, not misnumbered: an interior vertex pushed through a face
  // inverts tets whose order still agrees with their neighbours'.
  TetMesh f = make_box_mesh({.nx = 2, .ny = 2, .nz = 2});
  f.point(13)[0] += 1.6;  // the centre vertex (1,1,1) of the 3x3x3 lattice, moved past x = 2
  OrientationReport rf = normalize_orientation(f);
  ASSERT_FALSE(rf.inverted.empty());
  ASSERT_TRUE(build_topology(f).ok());
  EXPECT_TRUE(orient_consistently(f, false, &rf).ok());
}
