// Vertex insertion (insert.hpp): constrained faces and original coordinates
// bit-identical, new vertices appended and free, no inverted tet, volume per
// region conserved, validate() ok, worst alpha never lower.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <set>
#include <vector>

#include "tetopt/generate.hpp"
#include "tetopt/guard.hpp"
#include "tetopt/insert.hpp"
#include "tetopt/measures.hpp"
#include "tetopt/invariants.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/predicates.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/topo.hpp"
#include "detail/cone.hpp"

using namespace tetopt;

namespace {

std::set<std::array<int32_t, 3>> constrained_faces(const TetMesh& m) {
  std::set<std::array<int32_t, 3>> c;
  for (int32_t t = 0; t < m.nt(); ++t)
    for (int f = 0; f < 4; ++f)
      if (m.face_mask[t] & (1u << f)) {
        int32_t k[3];
        face_key(m, t, f, k);
        c.insert({k[0], k[1], k[2]});
      }
  return c;
}

// 5 x 5 x 5 cells, jitter 0.48: many poor tets, for insertion and removal.
TetMesh rough_box(int regions, uint64_t seed) {
  BoxMeshOptions bo;
  bo.nx = bo.ny = bo.nz = 5;
  bo.jitter = 0.48;
  bo.seed = seed;
  bo.regions = regions;
  return make_box_mesh(bo);
}

double worst(const TetMesh& m) {
  double w = 2;
  for (int32_t t = 0; t < m.nt(); ++t) w = std::min(w, tet_alpha(m, t));
  return w;
}

// The same tets, refs, constrained faces and coordinates, bit for bit.
void expect_same_mesh(const TetMesh& a, const TetMesh& b) {
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_EQ(a.tet_ref, b.tet_ref);
  EXPECT_EQ(a.face_mask, b.face_mask);
  ASSERT_EQ(a.xyz.size(), b.xyz.size());
  EXPECT_EQ(0, std::memcmp(a.xyz.data(), b.xyz.data(), a.xyz.size() * sizeof(double)));
}

}  // namespace

TEST(Insert, PassKeepsInvariantsAndAppendsFreeVertices) {
  int64_t inserted = 0;
  for (int regions : {1, 2})
    for (uint64_t seed : {1u, 2u, 3u}) {
      SCOPED_TRACE(regions * 100 + seed);
      TetMesh m = rough_box(regions, seed);
      ASSERT_TRUE(build_topology(m).ok());
      const std::vector<double> xyz = m.xyz;
      const auto faces = constrained_faces(m);
      const auto vols = region_volumes(m);
      const std::vector<uint8_t> vc = m.vert_constrained;
      const int32_t nv0 = m.nv();
      const double w0 = worst(m);
      InsertOptions o;
      o.quality_threshold = 0.4;
      const InsertStats st = insert_pass(m, o);
      ASSERT_TRUE(st.status.ok());
      inserted += st.inserted;
      EXPECT_EQ(m.nv(), nv0 + st.inserted);
      ASSERT_TRUE(validate(m, ValidateLevel::Full).ok());
      for (int32_t t = 0; t < m.nt(); ++t) {
        const int32_t* v = m.tet(t);
        ASSERT_EQ(orient3d(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3])), Sign::Positive);
      }
      EXPECT_EQ(0, std::memcmp(xyz.data(), m.xyz.data(), xyz.size() * sizeof(double)));
      EXPECT_EQ(faces, constrained_faces(m));
      for (int32_t v = 0; v < nv0; ++v) EXPECT_EQ(vc[v], m.vert_constrained[v]);
      for (int32_t v = nv0; v < m.nv(); ++v) {
        EXPECT_EQ(m.vert_constrained[v], 0);
        EXPECT_EQ(m.vert_ref[v], 0);
      }
      const auto vols2 = region_volumes(m);
      ASSERT_EQ(vols.size(), vols2.size());
      for (size_t i = 0; i < vols.size(); ++i) EXPECT_NEAR(vols[i].second, vols2[i].second, 1e-12);
      EXPECT_GE(worst(m), w0);
      EXPECT_GE(st.alpha_worst_after, st.alpha_worst_before);
      // classify() from scratch agrees with the incremental masks.
      const std::vector<uint8_t> mask = m.face_mask, kind = m.tet_kind;
      classify(m);
      EXPECT_EQ(mask, m.face_mask);
      EXPECT_EQ(kind, m.tet_kind);
    }
  RecordProperty("inserted", static_cast<int>(inserted));
  EXPECT_GT(inserted, 0);
}

// A slab one cell thick (every vertex on the boundary, as the impeller's
// shroud): flips and smoothing cannot touch its kind-4 tets, insertion of a
// vertex at mid-height must raise the worst alpha, and check_invariants()
// accepts the appended free vertices while the original ones are unchanged.
TEST(Insert, ThinSlabRaisesWorstAlphaAndPassesInvariantCheck) {
  BoxMeshOptions bo;
  bo.nx = bo.ny = 6;
  bo.nz = 1;
  TetMesh m = make_box_mesh(bo);
  // Planar in-plane jitter of the vertices off the side walls: the top and
  // bottom stay planar, the tets between them become poor.
  std::mt19937 g(1);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  for (int32_t v = 0; v < m.nv(); ++v) {
    double* p = &m.xyz[3 * static_cast<size_t>(v)];
    if (p[0] > 0 && p[0] < 6 && p[1] > 0 && p[1] < 6) {
      p[0] += u(g);
      p[1] += u(g);
    }
  }
  ASSERT_TRUE(build_topology(m).ok());
  ASSERT_TRUE(nonpositive_tets(m).empty());
  for (int32_t v = 0; v < m.nv(); ++v) ASSERT_TRUE(m.vert_constrained[v]);
  const InvariantSnapshot snap = capture_invariants(m);
  const int32_t nv0 = m.nv();
  const double w0 = worst(m);
  InsertOptions o;
  o.quality_threshold = 1.0;
  o.passes = 4;
  const InsertStats st = insert_pass(m, o);
  ASSERT_TRUE(st.status.ok());
  EXPECT_GT(st.inserted, 0);
  EXPECT_GT(worst(m), w0 + 1e-3);
  ASSERT_TRUE(validate(m, ValidateLevel::Full).ok());
  EXPECT_TRUE(check_invariants(m, snap).ok()) << check_invariants(m, snap).message;
  // The check must still catch a constrained newcomer and a lost vertex.
  ASSERT_GT(m.nv(), nv0);
  TetMesh bad = m;
  bad.vert_constrained[static_cast<size_t>(nv0)] = 1;
  EXPECT_FALSE(check_invariants(bad, snap).ok());
  TetMesh shrunk = m;
  shrunk.xyz.resize(3 * static_cast<size_t>(nv0 - 1));
  shrunk.vert_constrained.resize(static_cast<size_t>(nv0 - 1));
  EXPECT_FALSE(check_invariants(shrunk, snap).ok());
}

// InsertMemo: a pass that ended with nothing left to insert or remove,
// called again with its memo, tries nothing and changes nothing; a fresh
// pass without the memo tries those tets and agrees (refuses every one, the
// mesh unchanged bit for bit); moving one free vertex makes exactly the tets
// whose signature covers it worth a try again (the tets with it among their
// or their face neighbours' vertices, or in the star of one of their free
// vertices), and no other.
TEST(Insert, MemoSkipsWhatARefusalStillCoversAndNothingElse) {
  int64_t retried_total = 0;
  int star_only = 0;  // seeds whose moved vertex only a star covers
  for (uint64_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(seed);
    TetMesh m = rough_box(1, seed);
    ASSERT_TRUE(build_topology(m).ok());
    InsertMemo memo;
    InsertOptions o;
    o.quality_threshold = 0.4;
    o.remove = true;
    o.passes = 50;
    o.memo = &memo;
    const InsertStats first = insert_pass(m, o);
    ASSERT_TRUE(first.status.ok());
    ASSERT_FALSE(memo.refused.empty());
    const TetMesh settled = m;
    const InsertStats again = insert_pass(m, o);
    EXPECT_EQ(again.tried, 0);
    EXPECT_GT(again.skipped, 0);
    EXPECT_EQ(m.tets, settled.tets);
    EXPECT_EQ(m.xyz, settled.xyz);
    InsertOptions fresh = o;
    fresh.memo = nullptr;
    const InsertStats check = insert_pass(m, fresh);
    EXPECT_EQ(check.tried, again.skipped);
    EXPECT_EQ(check.inserted + check.removed, 0);
    EXPECT_EQ(m.tets, settled.tets);
    EXPECT_EQ(m.xyz, settled.xyz);
    // Move one free vertex by a hair (every tet stays positive): the tets
    // whose signature holds it are tried again.  Preferably a vertex that
    // some visited tet (alpha below the threshold, at least min_kind
    // constrained vertices) holds only through the star of one of its free
    // vertices, which a removal would replace.
    auto has = [&](int32_t t, int32_t u) {
      const int32_t* tv = m.tet(t);
      return tv[0] == u || tv[1] == u || tv[2] == u || tv[3] == u;
    };
    auto ring = [&](int32_t t, int32_t v) {
      if (has(t, v)) return true;
      for (int f = 0; f < 4; ++f)
        if (const int32_t nb = m.adj[4 * static_cast<size_t>(t) + f]; nb >= 0 && has(nb / 4, v)) return true;
      return false;
    };
    auto in_star = [&](int32_t t, int32_t v) {  // v in the star of a free vertex of t
      for (int k = 0; k < 4; ++k) {
        const int32_t u = m.tet(t)[k];
        if (m.vert_constrained[u]) continue;
        for (int32_t w = 0; w < m.nt(); ++w)
          if (has(w, u) && has(w, v)) return true;
      }
      return false;
    };
    auto visited = [&](int32_t t) { return tet_alpha(m, t) < o.quality_threshold && m.tet_kind[t] >= o.min_kind; };
    int32_t v = -1;
    for (int32_t u = 0; u < m.nv() && v < 0; ++u) {
      if (m.vert_constrained[u]) continue;
      for (int32_t t = 0; t < m.nt() && v < 0; ++t)
        if (visited(t) && !ring(t, u) && in_star(t, u)) v = u;
    }
    star_only += v >= 0;
    for (int32_t t = 0; t < m.nt() && v < 0; ++t)
      if (visited(t))
        for (int k = 0; k < 4 && v < 0; ++k)
          if (!m.vert_constrained[m.tet(t)[k]]) v = m.tet(t)[k];
    ASSERT_GE(v, 0);
    m.xyz[3 * static_cast<size_t>(v)] += 1e-9;
    for (int32_t t = 0; t < m.nt(); ++t) {
      const int32_t* tv = m.tet(t);
      ASSERT_EQ(orient3d(m.point(tv[0]), m.point(tv[1]), m.point(tv[2]), m.point(tv[3])), Sign::Positive);
    }
    int64_t covered = 0;
    for (int32_t t = 0; t < m.nt(); ++t) covered += visited(t) && (ring(t, v) || in_star(t, v));
    InsertOptions one = o;
    one.passes = 1;
    const InsertStats moved = insert_pass(m, one);
    EXPECT_GT(moved.tried, 0);
    if (moved.inserted + moved.removed == 0) {
      EXPECT_EQ(moved.tried, covered);
      EXPECT_EQ(moved.tried + moved.skipped, check.tried);
    } else {
      EXPECT_GE(moved.tried, covered);
    }
    retried_total += moved.tried;
  }
  RecordProperty("retried", static_cast<int>(retried_total));
  EXPECT_GT(star_only, 0) << "no seed exercised the stars";
}

// With threads the position searches run ahead in parallel (plan_inserts)
// and a search is used only where no commit since has written a tet it read:
// the pass must end bit for bit where the serial one ends, with some
// searches used and (on these rough boxes, where cavities overlap) some made
// again.  Also the promise: constrained faces, original coordinates.
TEST(Insert, SearchesMadeAheadGiveTheSerialResultBitForBit) {
  if (TopoEditor::plan_threads(2) < 2) GTEST_SKIP() << "no second thread (one hardware thread, or no oneTBB)";
  int64_t used = 0, redone = 0;
  for (int regions : {1, 2})
    for (uint64_t seed : {1u, 2u, 3u, 4u}) {
      SCOPED_TRACE(regions * 100 + seed);
      TetMesh m = rough_box(regions, seed);
      ASSERT_TRUE(build_topology(m).ok());
      const auto faces = constrained_faces(m);
      const std::vector<double> xyz = m.xyz;
      TetMesh serial = m, ahead = m;
      InsertMemo memo1, memo2;
      InsertOptions o;
      o.quality_threshold = 0.5;
      o.remove = true;
      o.passes = 4;
      o.memo = &memo1;
      o.threads = 1;
      const InsertStats s1 = insert_pass(serial, o);
      o.memo = &memo2;
      o.threads = 2;
      const InsertStats s2 = insert_pass(ahead, o);
      ASSERT_TRUE(s1.status.ok() && s2.status.ok());
      EXPECT_EQ(s1.planned_used + s1.planned_redone, 0);
      EXPECT_GT(s2.planned_used, 0);
      used += s2.planned_used;
      redone += s2.planned_redone;
      EXPECT_GT(s1.inserted, 0);
      EXPECT_EQ(s1.inserted, s2.inserted);
      EXPECT_EQ(s1.removed, s2.removed);
      EXPECT_EQ(s1.tried, s2.tried);
      expect_same_mesh(serial, ahead);
      EXPECT_EQ(0, std::memcmp(xyz.data(), ahead.xyz.data(), xyz.size() * sizeof(double)));
      EXPECT_EQ(faces, constrained_faces(ahead));
      ASSERT_TRUE(validate(ahead, ValidateLevel::Full).ok());
      for (int32_t t = 0; t < ahead.nt(); ++t) {
        const int32_t* v = ahead.tet(t);
        if (v[0] < 0) continue;
        ASSERT_EQ(orient3d(ahead.point(v[0]), ahead.point(v[1]), ahead.point(v[2]), ahead.point(v[3])), Sign::Positive);
      }
    }
  RecordProperty("used", static_cast<int>(used));
  RecordProperty("redone", static_cast<int>(redone));
  EXPECT_GT(redone, 0) << "no search was made again: the stale-read path went untested";
}

// Vertex removal (TopoEditor::remove_vertex, edge contraction) on jittered
// boxes: every removal raises the worst alpha of the star it replaces, so the
// mesh's worst alpha never drops; the removed vertices end unreferenced; the
// proof (check_invariants) accepts the result; compact_vertices then drops
// exactly them, and every constrained triangle and every kept vertex keeps
// its coordinates bit for bit under the new numbering.
TEST(Insert, VertexRemovalKeepsInvariantsAndCompactionRenumbers) {
  int64_t removed = 0;
  for (int regions : {1, 2})
    for (uint64_t seed : {1u, 2u, 3u}) {
      SCOPED_TRACE(regions * 100 + seed);
      TetMesh m = rough_box(regions, seed);
      ASSERT_TRUE(build_topology(m).ok());
      const InvariantSnapshot snap = capture_invariants(m);
      const TetMesh before = m;
      const double w0 = worst(m);
      std::vector<int32_t> gone;
      {
        TopoEditor ed(m, TopoOptions{});
        for (int32_t t = 0; t < m.nt(); ++t)
          if (ed.alive(t) && ed.cached_alpha(t) < 0.4) ed.remove_vertex(t);
        gone = ed.removed();
        EXPECT_EQ(ed.stats().removals, static_cast<int64_t>(gone.size()));
        ed.finish();
      }
      removed += static_cast<int64_t>(gone.size());
      EXPECT_GE(worst(m), w0);
      std::vector<uint8_t> used(m.nv(), 0);
      for (int32_t v : m.tets) used[v] = 1;
      for (int32_t v : gone) {
        EXPECT_FALSE(used[v]) << "removed vertex " << v << " still used";
        EXPECT_EQ(before.vert_constrained[v], 0);
      }
      ASSERT_TRUE(check_invariants(m, snap).ok());
      ASSERT_TRUE(validate(m, ValidateLevel::Full).ok());
      // A used vertex cannot be dropped; nothing changes then.
      if (!gone.empty()) {
        const std::vector<int32_t> bad = {m.tet(0)[0]};
        const std::vector<double> xyz = m.xyz;
        EXPECT_FALSE(compact_vertices(m, bad).ok());
        EXPECT_EQ(xyz, m.xyz);
      }
      std::vector<int32_t> map;
      ASSERT_TRUE(compact_vertices(m, gone, &map).ok());
      EXPECT_EQ(m.nv(), before.nv() - static_cast<int32_t>(gone.size()));
      for (int32_t v = 0; v < before.nv(); ++v) {
        if (map[v] < 0) continue;
        EXPECT_EQ(0, std::memcmp(before.point(v), m.point(map[v]), 3 * sizeof(double)));
        EXPECT_EQ(before.vert_constrained[v], m.vert_constrained[map[v]]);
      }
      ASSERT_EQ(before.tris.size(), m.tris.size());
      for (size_t i = 0; i < m.tris.size(); ++i)
        EXPECT_EQ(0, std::memcmp(before.point(before.tris[i]), m.point(m.tris[i]), 3 * sizeof(double)));
      ASSERT_TRUE(build_topology(m).ok());
      ASSERT_TRUE(validate(m, ValidateLevel::Full).ok());
      for (int32_t t = 0; t < m.nt(); ++t) {
        const int32_t* v = m.tet(t);
        ASSERT_EQ(orient3d(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3])), Sign::Positive);
      }
      const auto vols = region_volumes(before), vols2 = region_volumes(m);
      ASSERT_EQ(vols.size(), vols2.size());
      for (size_t i = 0; i < vols.size(); ++i) EXPECT_NEAR(vols[i].second, vols2[i].second, 1e-12);
    }
  RecordProperty("removed", static_cast<int>(removed));
  EXPECT_GT(removed, 0);
}

namespace {

// Every check the promise needs, between a mesh and what it became: the
// original vertices' coordinates and constraint flags bit for bit, the
// constrained faces as vertex triples, new vertices free, every tet exactly
// positive, volume per region, validate(Full), classify() agreeing with the
// incremental masks, and (when given) no tet below `floor`.
void expect_promise(const TetMesh& before, TetMesh& m, double floor) {
  const int32_t nv0 = before.nv();
  ASSERT_GE(m.nv(), nv0);
  EXPECT_EQ(0, std::memcmp(before.xyz.data(), m.xyz.data(), before.xyz.size() * sizeof(double)));
  for (int32_t v = 0; v < nv0; ++v) EXPECT_EQ(before.vert_constrained[v], m.vert_constrained[v]);
  for (int32_t v = nv0; v < m.nv(); ++v) EXPECT_EQ(m.vert_constrained[v], 0);
  EXPECT_EQ(constrained_faces(before), constrained_faces(m));
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = m.tet(t);
    ASSERT_EQ(orient3d(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3])), Sign::Positive);
    EXPECT_GE(tet_alpha(m, t), floor);
  }
  const auto vols = region_volumes(before), vols2 = region_volumes(m);
  ASSERT_EQ(vols.size(), vols2.size());
  for (size_t i = 0; i < vols.size(); ++i) EXPECT_NEAR(vols[i].second, vols2[i].second, 1e-9 * vols[i].second);
  ASSERT_TRUE(validate(m, ValidateLevel::Full).ok());
  const std::vector<uint8_t> mask = m.face_mask, kind = m.tet_kind;
  classify(m);
  EXPECT_EQ(mask, m.face_mask);
  EXPECT_EQ(kind, m.tet_kind);
}

double mean_alpha(const TetMesh& m) {
  double s = 0;
  for (int32_t t = 0; t < m.nt(); ++t) s += tet_alpha(m, t);
  return s / m.nt();
}

// A box of 4^3 cells whose interior vertices were collapsed away: almost
// every tet has four vertices on the boundary, like raw `tetgen -p` output.
TetMesh hollow_box() {
  BoxMeshOptions bo;
  bo.nx = bo.ny = bo.nz = 4;
  TetMesh m = make_box_mesh(bo);
  EXPECT_TRUE(build_topology(m).ok());
  std::vector<int32_t> gone;
  {
    TopoEditor ed(m, TopoOptions{});
    Acceptance any;
    any.on = true;
    any.floor = 1e-9;
    any.cap = 0;
    for (int pass = 0; pass < 8; ++pass)
      for (int32_t t = 0; t < m.nt(); ++t)
        for (int le = 0; le < 6 && ed.alive(t); ++le) ed.collapse_edge(t, le, any);
    gone = ed.removed();
    ed.finish();
  }
  EXPECT_TRUE(compact_vertices(m, gone).ok());
  EXPECT_TRUE(build_topology(m).ok());
  return m;
}

}  // namespace

// Edge splits (TopoEditor::split_edge) on jittered boxes, one and two
// regions: every interior edge on no constrained face may be split, each
// split appends one free vertex and turns a shell of n tets into 2n, the
// acceptance floor holds for every new tet, and the promise holds.  Edges on
// the boundary or an interface are refused.
TEST(Remesh, SplitEdgeKeepsThePromiseAndRefusesConstrainedEdges) {
  int64_t splits = 0, refused_boundary = 0;
  for (int regions : {1, 2}) {
    SCOPED_TRACE(regions);
    TetMesh m = rough_box(regions, 7);
    ASSERT_TRUE(build_topology(m).ok());
    const TetMesh before = m;
    const double w0 = worst(m);
    Acceptance acc;
    acc.on = true;
    acc.floor = w0;
    acc.cap = 0.3;
    acc.ratio = 0.9;
    {
      TopoEditor ed(m, TopoOptions{});
      const int32_t nt0 = m.nt();
      for (int32_t t = 0; t < nt0; ++t)
        for (int le = 0; le < 6; ++le) {
          if (!ed.alive(t)) break;
          const int32_t a = m.tet(t)[kEdgeVertex[le][0]], b = m.tet(t)[kEdgeVertex[le][1]];
          // An edge on a constrained face of t itself must be refused.
          bool on_constrained = false;
          for (int f = 0; f < 4; ++f)
            if ((m.face_mask[t] >> f) & 1u) {
              int in = 0;
              for (int k = 0; k < 3; ++k) {
                const int32_t v = m.tet(t)[kFaceVertex[f][k]];
                in += v == a || v == b;
              }
              on_constrained |= in == 2;
            }
          const int32_t nv = m.nv(), nt = m.nt();
          const TopoResult r = ed.split_edge(t, le, acc);
          if (on_constrained) {
            EXPECT_NE(r, TopoResult::Applied);
            ++refused_boundary;
          }
          if (r == TopoResult::Applied) {
            ++splits;
            EXPECT_EQ(m.nv(), nv + 1);
            EXPECT_GE(m.nt(), nt);
          } else {
            EXPECT_EQ(m.nv(), nv);  // a refused split leaves no vertex behind
          }
        }
      EXPECT_EQ(ed.stats().splits, ed.stats().insertions);
      ed.finish();
    }
    expect_promise(before, m, std::min(w0, 0.9 * 0.3) * (1 - 1e-12));
    EXPECT_GE(worst(m), w0);
  }
  RecordProperty("splits", static_cast<int>(splits));
  EXPECT_GT(splits, 100);
  EXPECT_GT(refused_boundary, 100);
}

// remesh_pass on a box with no interior vertex: the long interior edges are
// split toward the size field (for these raw vertices the larger of the
// boundary triangles' edge lengths and the graded mean edge length), the
// remesher's own short edges collapsed, and the promise holds; the worst
// alpha does not fall and the mean rises.  With --size-like sizes the mesh
// is refined accordingly.
TEST(Remesh, PassRefinesAMeshWithNoInteriorVertex) {
  TetMesh m = hollow_box();
  int32_t free_used = 0;
  {
    std::vector<uint8_t> used(m.nv(), 0);
    for (int32_t v : m.tets) used[v] = 1;
    for (int32_t v = 0; v < m.nv(); ++v) free_used += used[v] && !m.vert_constrained[v];
  }
  // Two of the 27 interior vertices cannot be contracted onto any neighbour
  // without inverting a tet (the fixture's own collapse refuses them).
  ASSERT_LE(free_used, 2) << "the fixture should have almost no interior vertex";
  const TetMesh before = m;
  const double w0 = worst(m), mean0 = mean_alpha(m);
  std::vector<double> h;
  RemeshOptions ro;
  ro.sweeps = 3;
  ro.removable_from = m.nv();
  const RemeshStats st = remesh_pass(m, h, ro);
  ASSERT_TRUE(st.status.ok());
  EXPECT_GT(st.splits, 0);
  EXPECT_EQ(h.size(), static_cast<size_t>(m.nv()));
  for (int32_t v : st.removed_vertices) EXPECT_GE(v, before.nv());  // only the remesher's own
  ASSERT_TRUE(compact_vertices(m, st.removed_vertices).ok());
  ASSERT_TRUE(build_topology(m).ok());
  expect_promise(before, m, w0);
  EXPECT_GT(mean_alpha(m), mean0);
  // A smaller target size gives more vertices.
  TetMesh fine = before;
  std::vector<double> hf;
  ro.size = 0.5;
  const RemeshStats sf = remesh_pass(fine, hf, ro);
  ASSERT_TRUE(sf.status.ok());
  EXPECT_GT(fine.nv() - static_cast<int32_t>(sf.removed_vertices.size()),
            m.nv());
  ASSERT_TRUE(compact_vertices(fine, sf.removed_vertices).ok());
  ASSERT_TRUE(build_topology(fine).ok());
  expect_promise(before, fine, w0);
}

namespace {

// A slab one cell thick, jittered in its plane off the side walls (top and
// bottom stay planar): every vertex is on the boundary, so no vertex is
// free, and the tets differ (in the regular slab every tet is the worst).
TetMesh jittered_slab() {
  BoxMeshOptions bo;
  bo.nx = bo.ny = 5;
  bo.nz = 1;
  TetMesh m = make_box_mesh(bo);
  std::mt19937 g(3);
  std::uniform_real_distribution<double> u(-0.25, 0.25);
  for (int32_t v = 0; v < m.nv(); ++v) {
    double* p = &m.xyz[3 * static_cast<size_t>(v)];
    if (p[0] > 0 && p[0] < 5 && p[1] > 0 && p[1] < 5) {
      p[0] += u(g);
      p[1] += u(g);
    }
  }
  EXPECT_TRUE(build_topology(m).ok());
  return m;
}

}  // namespace

// A slab one cell thick: the long body diagonals are still split (the
// worst alpha is a floor the splits respect) and the promise holds.
TEST(Remesh, PassWorksWithNoFreeVertexAtAll) {
  TetMesh m = jittered_slab();
  ASSERT_TRUE(nonpositive_tets(m).empty());
  for (int32_t v = 0; v < m.nv(); ++v) ASSERT_TRUE(m.vert_constrained[v]);
  const TetMesh before = m;
  const double w0 = worst(m);
  std::vector<double> h;
  RemeshOptions ro;
  ro.removable_from = m.nv();
  ro.size = 1.0;  // the body diagonals (sqrt 3) are long, the cells' edges not
  const RemeshStats st = remesh_pass(m, h, ro);
  ASSERT_TRUE(st.status.ok());
  EXPECT_GT(st.splits, 0);
  ASSERT_TRUE(compact_vertices(m, st.removed_vertices).ok());
  ASSERT_TRUE(build_topology(m).ok());
  expect_promise(before, m, w0);
}

// split_locked_worst: the worst tet of the slab has four constrained
// vertices (every vertex is); it gets an edge split, a free vertex, and the
// tets at the old worst alpha are gone, the promise kept.  Where the worst
// tet has a free vertex (the jittered box) nothing changes.
TEST(Insert, SplitLockedWorstGivesTheWorstTetAFreeVertex) {
  TetMesh m = jittered_slab();
  const TetMesh before = m;
  const double w0 = worst(m);
  const InsertOptions io;
  auto at_worst = [&](const TetMesh& x) {
    int64_t n = 0;
    for (int32_t t = 0; t < x.nt(); ++t) n += tet_alpha(x, t) <= w0 + io.margin;
    return n;
  };
  ASSERT_GT(at_worst(m), 0);
  const int64_t split = split_locked_worst(m, io);
  EXPECT_GT(split, 0);
  EXPECT_EQ(m.nv(), before.nv() + split);
  EXPECT_EQ(at_worst(m), 0);
  EXPECT_GT(worst(m), w0);
  expect_promise(before, m, w0);

  TetMesh box = rough_box(1, 7);
  ASSERT_TRUE(build_topology(box).ok());
  double w = 2;
  int kind = -1;
  for (int32_t t = 0; t < box.nt(); ++t)
    if (tet_alpha(box, t) < w) w = tet_alpha(box, t), kind = box.tet_kind[t];
  ASSERT_LT(kind, 4);
  const TetMesh box0 = box;
  EXPECT_EQ(split_locked_worst(box, io), 0);
  expect_same_mesh(box0, box);
}

// split_locked_worst with `forced`: under guards taken on a mesh of far
// better tets (a regular box), no split of the slab's worst tet passes and
// the plain call changes nothing; the forced call ignores the guards and
// splits, its new tets keeping half the tet's alpha at least, the promise
// kept.  improve() runs the rounds after such a split and keeps them only
// where the guarded measures end no worse (script.test_forced_split).
TEST(Insert, ForcedLockedSplitIgnoresTheGuardsAndKeepsHalfTheAlpha) {
  TetMesh m = jittered_slab();
  const TetMesh before = m;
  const double w0 = worst(m);
  BoxMeshOptions bo;
  bo.nx = bo.ny = bo.nz = 2;
  bo.jitter = 0;
  TetMesh good = make_box_mesh(bo);
  ASSERT_TRUE(build_topology(good).ok());
  Guard g;
  Guard::take(good, 1, g);
  ASSERT_GT(g.extreme(Measure::Alpha), 1.5 * w0);  // 0.59 against 0.37
  InsertOptions io;
  io.guard = &g;
  EXPECT_EQ(split_locked_worst(m, io), 0);
  expect_same_mesh(before, m);
  const int64_t split = split_locked_worst(m, io, 0.5);
  EXPECT_GT(split, 0);
  EXPECT_EQ(m.nv(), before.nv() + split);
  EXPECT_GE(worst(m), 0.5 * w0);
  expect_promise(before, m, 0.5 * w0);
}

namespace {

// The per-vertex sizes remesh_pass's size field starts from: the mean length
// of the constrained triangles' edges at a vertex (0 when it is on none),
// the mean length of every edge at it (each counted once per tet, as MMG3D
// counts them), and whether some tet at it has a free vertex.
struct InputSizes {
  std::vector<double> surf, all;
  std::vector<uint8_t> free_near;
};

InputSizes input_sizes(const TetMesh& m) {
  InputSizes s;
  std::vector<int32_t> nc(m.nv(), 0), na(m.nv(), 0);
  s.surf.assign(m.nv(), 0.0);
  s.all.assign(m.nv(), 0.0);
  s.free_near.assign(m.nv(), 0);
  auto len = [&](int32_t a, int32_t b) {
    const double* p = m.point(a);
    const double* q = m.point(b);
    return std::sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]));
  };
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = m.tet(t);
    bool any_free = false;
    for (int i = 0; i < 4; ++i) any_free = any_free || !m.vert_constrained[v[i]];
    for (int i = 0; i < 4; ++i) {
      if (any_free) s.free_near[v[i]] = 1;
      for (int j = i + 1; j < 4; ++j) {
        const double l = len(v[i], v[j]);
        s.all[v[i]] += l;
        s.all[v[j]] += l;
        ++na[v[i]];
        ++na[v[j]];
      }
    }
    for (int f = 0; f < 4; ++f) {
      if (!((m.face_mask[t] >> f) & 1u)) continue;
      for (int k = 0; k < 3; ++k) {
        const int32_t a = v[kFaceVertex[f][k]], b = v[kFaceVertex[f][(k + 1) % 3]];
        const double l = len(a, b);
        s.surf[a] += l;
        s.surf[b] += l;
        ++nc[a];
        ++nc[b];
      }
    }
  }
  for (int32_t v = 0; v < m.nv(); ++v) {
    if (nc[v]) s.surf[v] /= nc[v];
    if (na[v]) s.all[v] /= na[v];
  }
  return s;
}

}  // namespace

// The size field on a raw mesh (no interior vertex): a constrained vertex
// whose tets have no free vertex takes the larger of its surface size and
// the mean length of its edges graded by 0.15 per unit length (insert.hpp),
// so it is never finer than the surface size, never coarser than its own
// edges' mean where the graded size decides, and the graded sizes grow by
// at most 0.15 |vw| along every edge.  On a mesh with interior vertices
// every constrained vertex keeps its surface size (as before the gradation
// existed).
TEST(Remesh, SizeFieldOfARawMeshIsGradedAndNeverFinerThanTheSurface) {
  constexpr double g = 0.15, eps = 1e-12;
  TetMesh m = hollow_box();
  const InputSizes in = input_sizes(m);
  const int32_t nv = m.nv();
  std::vector<double> h;
  RemeshOptions ro;
  ro.removable_from = nv;
  ro.max_loops = 1;
  ASSERT_TRUE(remesh_pass(m, h, ro).status.ok());
  ASSERT_GE(h.size(), static_cast<size_t>(nv));
  int coarser = 0;
  for (int32_t v = 0; v < nv; ++v) {
    if (!m.vert_constrained[v] || in.free_near[v]) continue;  // not raw
    EXPECT_GE(h[v], in.surf[v] * (1 - eps)) << v;
    if (!(h[v] > in.surf[v] * (1 + eps))) continue;
    ++coarser;
    EXPECT_LE(h[v], in.all[v] * (1 + eps)) << v;
  }
  EXPECT_GT(coarser, 0) << "the graded size never decided";
  // The gradation along the input's edges (the remesher kept every input
  // vertex and their coordinates, not every edge: checked on a copy).
  const TetMesh raw = hollow_box();
  for (int32_t t = 0; t < raw.nt(); ++t) {
    const int32_t* tv = raw.tet(t);
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        const int32_t v = tv[i], w = tv[j];
        if (v == w || !raw.vert_constrained[v] || in.free_near[v] || !(h[v] > in.surf[v] * (1 + eps))) continue;
        // h[v] is graded there; the graded size at w is at most h[w] when
        // w is raw or free (free: its edges' mean, where the gradation
        // starts; raw: the larger of two).
        if (raw.vert_constrained[w] && in.free_near[w]) continue;
        const double* p = raw.point(v);
        const double* q = raw.point(w);
        const double l =
            std::sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]));
        EXPECT_LE(h[v], (h[w] + g * l) * (1 + eps)) << v << " " << w;
      }
  }
  // A mesh with interior vertices: constrained vertices keep the surface size.
  BoxMeshOptions bo;
  bo.nx = bo.ny = bo.nz = 4;
  TetMesh box = make_box_mesh(bo);
  ASSERT_TRUE(build_topology(box).ok());
  const InputSizes ib = input_sizes(box);
  const int32_t nb = box.nv();
  std::vector<double> hb;
  ASSERT_TRUE(remesh_pass(box, hb, ro).status.ok());
  int kept = 0;
  for (int32_t v = 0; v < nb; ++v) {
    if (!box.vert_constrained[v] || !ib.free_near[v]) continue;
    EXPECT_NEAR(hb[v], ib.surf[v], eps * ib.surf[v]) << v;
    ++kept;
  }
  EXPECT_GT(kept, 0);
}

namespace {

// Circumcentre and circumradius of tet t, solved here from the three
// equations |x - v_i|^2 = |x - v_0|^2 by Cramer's rule (independent of the
// library's own formula).
double circumradius(const TetMesh& m, int32_t t, double* cc) {
  const int32_t* v = m.tet(t);
  const double* p0 = m.point(v[0]);
  double a[3][3], r[3];
  for (int i = 0; i < 3; ++i) {
    const double* p = m.point(v[i + 1]);
    r[i] = 0;
    for (int k = 0; k < 3; ++k) {
      a[i][k] = 2 * (p[k] - p0[k]);
      r[i] += p[k] * p[k] - p0[k] * p0[k];
    }
  }
  auto det = [](const double (&b)[3][3]) {
    return b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1]) - b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0]) +
           b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
  };
  const double d = det(a);
  for (int k = 0; k < 3; ++k) {
    double b[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) b[i][j] = j == k ? r[i] : a[i][j];
    cc[k] = det(b) / d;
  }
  return std::sqrt((cc[0] - p0[0]) * (cc[0] - p0[0]) + (cc[1] - p0[1]) * (cc[1] - p0[1]) +
                   (cc[2] - p0[2]) * (cc[2] - p0[2]));
}

void centroid(const TetMesh& m, int32_t t, double* x) {
  for (int k = 0; k < 3; ++k) x[k] = 0;
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 3; ++k) x[k] += 0.25 * m.point(m.tet(t)[i])[k];
}

int local_of_vertex(const int32_t* tv, int32_t v) {
  for (int i = 0; i < 4; ++i)
    if (tv[i] == v) return i;
  return -1;
}

bool has_edge(const TetMesh& m, int32_t a, int32_t b) {
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = m.tet(t);
    if (local_of_vertex(v, a) >= 0 && local_of_vertex(v, b) >= 0) return true;
  }
  return false;
}

}  // namespace

// Point insertion by a Bowyer-Watson cavity (TopoEditor::insert_point) on
// jittered boxes, one and two regions: a point inserted appends one free
// vertex at exactly that point, every new tet holds it and lies in the
// seed's region, the acceptance floor holds, a refused point leaves no
// vertex; a point outside the box, or across the interface of the two
// regions, is refused; the promise holds at the end.
TEST(Remesh, InsertPointKeepsThePromiseAndStaysInItsRegion) {
  for (int regions : {1, 2}) {
    SCOPED_TRACE(regions);
    TetMesh m = rough_box(regions, 11);
    ASSERT_TRUE(build_topology(m).ok());
    const TetMesh before = m;
    const double w0 = worst(m);
    Acceptance acc;
    acc.on = true;
    acc.floor = w0;
    acc.cap = 0.3;
    acc.ratio = 0.9;
    int applied = 0, refused = 0, across = 0;
    {
      TopoEditor ed(m, TopoOptions{});
      const int32_t nt0 = m.nt();
      std::vector<int32_t> made;
      for (int32_t t = 0; t < nt0; t += 3) {
        if (!ed.alive(t)) continue;
        double x[3];
        centroid(m, t, x);
        const int32_t nv = m.nv(), ref = m.tet_ref[t];
        const TopoResult r = ed.insert_point(t, x, acc, 0, &made);
        if (r != TopoResult::Applied) {
          EXPECT_EQ(m.nv(), nv);
          ++refused;
          continue;
        }
        ++applied;
        ASSERT_EQ(m.nv(), nv + 1);
        EXPECT_EQ(0, std::memcmp(m.point(nv), x, sizeof x));
        ASSERT_GE(made.size(), 4u);
        for (int32_t n : made) {
          ASSERT_TRUE(ed.alive(n));
          EXPECT_GE(local_of_vertex(m.tet(n), nv), 0);
          EXPECT_EQ(m.tet_ref[n], ref);
          EXPECT_GE(tet_alpha(m, n), w0);
        }
      }
      // Outside the box: the walk meets the boundary.
      int32_t t0 = 0;
      while (!ed.alive(t0)) ++t0;
      const double out[3] = {-1, -1, -1};
      const int32_t nv = m.nv();
      EXPECT_EQ(ed.insert_point(t0, out, acc), TopoResult::BoundaryLocked);
      EXPECT_EQ(m.nv(), nv);
      // Across the interface: a point inside a tet of the other region.
      if (regions == 2)
        for (int32_t t = 0; t < m.nt() && across < 20; ++t) {
          if (!ed.alive(t) || m.tet_ref[t] == m.tet_ref[t0]) continue;
          double x[3];
          centroid(m, t, x);
          EXPECT_NE(ed.insert_point(t0, x, acc), TopoResult::Applied);
          EXPECT_EQ(m.nv(), nv);
          ++across;
        }
      ed.finish();
    }
    expect_promise(before, m, w0);
    EXPECT_GE(worst(m), w0);
    EXPECT_GT(applied, 20);
    EXPECT_GT(refused, 0);
    if (regions == 2) {
      EXPECT_EQ(across, 20);
    }
  }
}

// insert_point refuses a point too close to a cavity vertex (min_dist), and
// never removes a listed edge: an interior edge whose midpoint is inserted
// when the edge is not listed is kept (the insertion refused) once listed.
TEST(Remesh, InsertPointKeepsDistanceAndListedEdges) {
  TetMesh m = rough_box(1, 5);
  ASSERT_TRUE(build_topology(m).ok());
  Acceptance any;
  any.on = true;
  any.floor = 1e-12;
  any.cap = 0;
  // A point 1e-3 of the way from a vertex to the tet's centroid.
  {
    TetMesh c = m;
    TopoEditor ed(c, TopoOptions{});
    int32_t t = 0;
    while (c.vert_constrained[c.tet(t)[0]]) ++t;
    double x[3], g[3];
    centroid(c, t, g);
    const double* p = c.point(c.tet(t)[0]);
    for (int k = 0; k < 3; ++k) x[k] = p[k] + 1e-3 * (g[k] - p[k]);
    EXPECT_EQ(ed.insert_point(t, x, any, 0.05), TopoResult::NotApplicable);
    EXPECT_EQ(c.nv(), m.nv());
  }
  int tried = 0;
  for (int32_t t = 0; t < m.nt() && tried < 5; ++t)
    for (int le = 0; le < 6 && tried < 5; ++le) {
      const int32_t a = m.tet(t)[kEdgeVertex[le][0]], b = m.tet(t)[kEdgeVertex[le][1]];
      if (m.vert_constrained[a] || m.vert_constrained[b]) continue;
      double x[3];
      for (int k = 0; k < 3; ++k) x[k] = 0.5 * (m.point(a)[k] + m.point(b)[k]);
      TetMesh free_edge = m;
      {
        TopoEditor ed(free_edge, TopoOptions{});
        if (ed.insert_point(t, x, any) != TopoResult::Applied) continue;
        ed.finish();
      }
      ++tried;
      EXPECT_FALSE(has_edge(free_edge, a, b));  // the midpoint's cavity took the edge
      TetMesh listed = m;
      listed.edges = {a, b};
      listed.edge_ref = {1};
      ASSERT_TRUE(build_topology(listed).ok());
      {
        TopoEditor ed(listed, TopoOptions{});
        EXPECT_NE(ed.insert_point(t, x, any), TopoResult::Applied);
        ed.finish();
      }
      EXPECT_EQ(listed.nv(), m.nv());
      EXPECT_TRUE(has_edge(listed, a, b));
    }
  EXPECT_EQ(tried, 5);
}

// refine_pass on a box with no interior vertex (like raw `tetgen -p`
// output): circumcentres go in, the share of tets too large for the size
// field falls, every new vertex gets a size, the promise holds with the worst
// alpha as floor, and the result does not depend on anything but the input.
TEST(Remesh, RefinePassFillsAMeshWithNoInteriorVertex) {
  const TetMesh before = hollow_box();
  TetMesh m = before;
  const double w0 = worst(m);
  std::vector<double> h;
  const RefineOptions fo;
  const RefineStats st = refine_pass(m, h, fo);
  ASSERT_TRUE(st.status.ok());
  EXPECT_GT(st.inserted, 0);
  EXPECT_EQ(st.inserted, m.nv() - before.nv());
  ASSERT_EQ(h.size(), static_cast<size_t>(m.nv()));
  auto large = [&](const TetMesh& x) {
    int n = 0;
    for (int32_t t = 0; t < x.nt(); ++t) {
      double cc[3];
      const int32_t* v = x.tet(t);
      const double size = 0.25 * (h[v[0]] + h[v[1]] + h[v[2]] + h[v[3]]);
      n += circumradius(x, t, cc) > fo.radius_above * size;
    }
    return n;
  };
  const int large_before = large(before), large_after = large(m);
  RecordProperty("large_before", large_before);
  RecordProperty("large_after", large_after);
  EXPECT_EQ(large_before, st.large);
  // Tets whose circumcentre lies beyond the boundary, or whose insertion
  // would make a tet below the acceptance floor, stay: their share at least
  // halves (151 of 235 tets before, 96 of 364 after, when written).
  EXPECT_LT(large_after, large_before);
  EXPECT_LT(2.0 * large_after / m.nt(), 1.0 * large_before / before.nt());
  expect_promise(before, m, w0);
  TetMesh again = before;
  std::vector<double> h2;
  ASSERT_TRUE(refine_pass(again, h2, fo).status.ok());
  EXPECT_EQ(again.tets, m.tets);
  EXPECT_EQ(again.xyz, m.xyz);
  // A smaller size gives more vertices.
  TetMesh fine = before;
  std::vector<double> hf;
  RefineOptions ff;
  ff.size = 0.5;
  const RefineStats sf = refine_pass(fine, hf, ff);
  ASSERT_TRUE(sf.status.ok());
  EXPECT_GT(sf.inserted, st.inserted);
  expect_promise(before, fine, w0);
}

// refine_pass on a raw mesh grades its vertices' sizes from the wall
// (insert.hpp, RefineOptions): a raw constrained vertex keeps its surface
// size (remesh_pass's graded size, larger at some of them, is only a cap),
// and a circumcentre takes at most the least size at its tet's vertices plus
// log(1.3) times its distance from them (not checked here: in a mesh that
// is not Delaunay another vertex may be nearer than the tet's four), and
// never more than the cap: no new vertex is finer than the finest surface
// size or coarser than the largest graded size, and some are coarser than
// the surface.
TEST(Remesh, RefineGradesNewSizesFromTheSurface) {
  constexpr double eps = 1e-9;
  const TetMesh before = hollow_box();
  const InputSizes in = input_sizes(before);
  const int32_t nv0 = before.nv();
  TetMesh m = before;
  std::vector<double> h;
  const RefineStats st = refine_pass(m, h, RefineOptions{});
  ASSERT_TRUE(st.status.ok());
  ASSERT_GT(st.inserted, 0);
  ASSERT_EQ(h.size(), static_cast<size_t>(m.nv()));
  // remesh_pass's field on the same input: the graded sizes.
  TetMesh copy = before;
  std::vector<double> hg;
  RemeshOptions ro;
  ro.max_loops = 1;
  ASSERT_TRUE(remesh_pass(copy, hg, ro).status.ok());
  int raw = 0, graded = 0;
  double cap = 0, finest = std::numeric_limits<double>::infinity();
  for (int32_t v = 0; v < nv0; ++v) {
    cap = std::max(cap, hg[v]);
    if (!before.vert_constrained[v] || in.free_near[v]) continue;
    ++raw;
    finest = std::min(finest, in.surf[v]);
    EXPECT_NEAR(h[v], in.surf[v], eps * in.surf[v]) << v;
    graded += hg[v] > in.surf[v] * (1 + 1e-6);
  }
  EXPECT_GT(raw, 0);
  EXPECT_GT(graded, 0) << "the graded size never exceeded the surface size: nothing to tell apart";
  int coarser = 0;
  for (int32_t v = nv0; v < m.nv(); ++v) {
    EXPECT_GE(h[v], finest * (1 - eps)) << v;
    EXPECT_LE(h[v], cap * (1 + eps)) << v;
    coarser += h[v] > finest * (1 + 1e-6);
  }
  EXPECT_GT(coarser, 0) << "no new vertex grew coarser than the wall";
  expect_promise(before, m, worst(before));
}

// With threads, refine_pass searches the cavities of a window of the heap's
// top entries ahead, in parallel (TopoEditor::plan_points), keeps the heap's
// order by pushing a window's rest back when a new tet comes first, and uses
// a search only where no commit since wrote a tet it read: the result must
// be the serial one bit for bit, with searches used, searches made again
// and entries pushed back all seen.
TEST(Remesh, RefineSearchesMadeAheadGiveTheSerialResultBitForBit) {
  if (TopoEditor::plan_threads(2) < 2) GTEST_SKIP() << "no second thread (one hardware thread, or no oneTBB)";
  int64_t used = 0, redone = 0, pushed = 0;
  for (double size : {0.0, 0.5, 0.35}) {
    SCOPED_TRACE(size);
    const TetMesh before = hollow_box();
    const double w0 = worst(before);
    TetMesh serial = before, ahead = before;
    std::vector<double> h1, h2;
    RefineOptions fo;
    fo.size = size;
    fo.threads = 1;
    const RefineStats s1 = refine_pass(serial, h1, fo);
    fo.threads = 2;
    const RefineStats s2 = refine_pass(ahead, h2, fo);
    ASSERT_TRUE(s1.status.ok() && s2.status.ok());
    EXPECT_EQ(s1.planned_used + s1.planned_redone + s1.pushed_back, 0);
    EXPECT_GT(s1.inserted, 0);
    EXPECT_EQ(s1.inserted, s2.inserted);
    EXPECT_EQ(s1.tried, s2.tried);
    expect_same_mesh(serial, ahead);
    EXPECT_EQ(h1, h2);
    expect_promise(before, ahead, w0);
    used += s2.planned_used;
    redone += s2.planned_redone;
    // Most searches are used, on the raw box's own (wall-graded) sizes too:
    // a search is kept only for the same point and distance, so a plan made
    // with another size than its insertion's would always be made again.
    EXPECT_GT(s2.planned_used, 2 * s2.planned_redone);
    pushed += s2.pushed_back;
  }
  RecordProperty("used", static_cast<int>(used));
  RecordProperty("redone", static_cast<int>(redone));
  RecordProperty("pushed_back", static_cast<int>(pushed));
  EXPECT_GT(used, 0);
  EXPECT_GT(redone, 0) << "no search was made again: the stale-read path went untested";
  EXPECT_GT(pushed, 0) << "no window was cut short: the order path went untested";
}

// insert_vertex's position search runs on detail::cone_alpha, which must be
// alpha(A, C, B, p) bit for bit (the same operations in the same order), or
// insertion would accept tets by numbers the rest of the engine does not see.
TEST(Remesh, ConeAlphaIsAlphaBitForBit) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  int64_t positive = 0, zero = 0, checked = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    double A[3], B[3], C[3], p[3];
    for (int k = 0; k < 3; ++k) { A[k] = u(rng); B[k] = u(rng); C[k] = u(rng); p[k] = u(rng); }
    if (trial % 4 == 1)  // near-flat: p close to the face's plane
      for (int k = 0; k < 3; ++k) p[k] = (A[k] + B[k] + C[k]) / 3 + 1e-9 * u(rng);
    if (trial % 4 == 2)  // a needle face: C next to B
      for (int k = 0; k < 3; ++k) C[k] = B[k] + 1e-7 * u(rng);
    if (trial % 4 == 3)  // far apex, large offset coordinates
      for (int k = 0; k < 3; ++k) { A[k] += 1e4; B[k] += 1e4; C[k] += 1e4; p[k] = 1e4 + 50 * u(rng); }
    if (trial % 97 == 5)  // a degenerate face (A = B): alpha 0 by its zero-area branch
      for (int k = 0; k < 3; ++k) B[k] = A[k];
    detail::ConeFace f;
    detail::make_cone_face(A, B, C, f);
    const double want = alpha(A, C, B, p), got = detail::cone_alpha(f, p);
    EXPECT_EQ(std::memcmp(&want, &got, sizeof want), 0) << "trial " << trial << ": " << want << " vs " << got;
    // The four-lane form the search runs on (cone_alpha4, SIMD): the same
    // bits in every lane, here as face trial % 7 of a fan of 7 faces whose
    // other faces are random and whose eighth lane is padding.
    detail::ConeFan<8> fan;
    const int at = trial % 7, lane = at % 4, block = at / 4;
    for (int i = 0; i < 7; ++i) {
      double X[3], Y[3], Z[3];
      for (int k = 0; k < 3; ++k) { X[k] = u(rng); Y[k] = u(rng); Z[k] = u(rng); }
      if (i == at) fan.set(i, A, B, C);
      else fan.set(i, X, Y, Z);
    }
    fan.pad(7);
    double q[4];
    detail::cone_alpha4(fan, 4 * block, p, q);
    EXPECT_EQ(std::memcmp(&want, &q[lane], sizeof want), 0) << "trial " << trial << ": " << want << " vs " << q[lane];
    if (trial % 2) {  // lane 3 of block 1 is the padding: a copy of face 0
      double pad[4], first[4];
      detail::cone_alpha4(fan, 0, p, first);
      detail::cone_alpha4(fan, 4, p, pad);
      EXPECT_EQ(std::memcmp(&first[0], &pad[3], sizeof pad[3]), 0);
    }
    positive += want > 0;
    zero += want == 0;
    ++checked;
  }
  EXPECT_GT(positive, checked / 4);  // both orientations and degenerate cases were met
  EXPECT_LT(positive, checked);
  EXPECT_GT(zero, 0);
}

// Guard::slack is the margin admits() decides by: not negative exactly
// when admits() holds, on random tets against a guard from a jittered box.
TEST(Remesh, GuardSlackAgreesWithAdmits) {
  TetMesh m = rough_box(1, 4);
  ASSERT_TRUE(build_topology(m).ok());
  Guard g;
  Guard::take(m, 1, g);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(0, 1);
  int admitted = 0, refused = 0;
  for (int trial = 0; trial < 5000; ++trial) {
    double p[4][3];
    for (auto& q : p)
      for (double& x : q) x = u(rng);
    if (trial % 2) g.exempt(Measure::ScaledJacobian);
    else g.exempt_none();
    const bool a = g.admits(p[0], p[1], p[2], p[3]);
    const double s = g.slack(p[0], p[1], p[2], p[3]);
    EXPECT_EQ(a, s >= 0) << "trial " << trial << " slack " << s;
    (a ? admitted : refused)++;
  }
  EXPECT_GT(admitted, 100);
  EXPECT_GT(refused, 100);
}

// When the guard refuses the cone at the alpha-best position (here: the
// scaled Jacobian's extreme set just above what that cone makes),
// insert_vertex moves the new vertex to where the guard admits every new
// tet and the worst alpha still rises (guarded_position), instead of giving
// up: on cylinder_hole.geo's raw mesh at --size 0.06 a tet of alpha 0.0589
// stayed for a whole run that way.
TEST(Remesh, InsertVertexFindsAPositionTheGuardAdmits) {
  int tried = 0, found = 0;
  for (uint64_t seed : {1u, 2u, 3u, 4u, 5u, 6u}) {
    TetMesh m0 = rough_box(1, seed);
    ASSERT_TRUE(build_topology(m0).ok());
    // The worst tet with no constrained face: its cavity can grow freely.
    int32_t t = -1;
    for (int32_t k = 0; k < m0.nt(); ++k)
      if (m0.face_mask[k] == 0 && (t < 0 || tet_alpha(m0, k) < tet_alpha(m0, t))) t = k;
    ASSERT_GE(t, 0);
    // Without a guard: where the alpha-best insertion goes, and the least
    // scaled Jacobian of the tets it makes.
    TetMesh m1 = m0;
    double sj_free = INFINITY;
    {
      TopoOptions o;
      TopoEditor ed(m1, o);
      if (ed.insert_vertex(t) != TopoResult::Applied) continue;
      ed.finish();
    }
    const int32_t nv = m0.nv();
    ASSERT_EQ(m1.nv(), nv + 1);
    for (int32_t k = 0; k < m1.nt(); ++k) {
      const int32_t* v = m1.tet(k);
      if (v[0] == nv || v[1] == nv || v[2] == nv || v[3] == nv)
        sj_free = std::min(sj_free, scaled_jacobian(m1.point(v[0]), m1.point(v[1]), m1.point(v[2]), m1.point(v[3])));
    }
    // A guard on the scaled Jacobian alone, its extreme 20% above sj_free:
    // taken from a regular lattice box (every extreme better) with that
    // floor set, so the old tets' own values do not matter.
    BoxMeshOptions lo;
    lo.nx = lo.ny = lo.nz = 2;
    TetMesh lattice = make_box_mesh(lo);
    ASSERT_TRUE(build_topology(lattice).ok());
    Guard g;
    Guard::take(lattice, 1, g);
    const double x = 1.2 * sj_free;
    if (!(x < g.extreme(Measure::ScaledJacobian))) continue;
    std::array<double, kTetMeasureCount> floor;
    floor.fill(NAN);
    floor[static_cast<size_t>(Measure::ScaledJacobian)] = x;
    g.set_floor(floor);
    Guard::take(lattice, 1, g);
    for (int k = 0; k < kTetMeasureCount; ++k)
      if (k != static_cast<int>(Measure::ScaledJacobian)) g.exempt(static_cast<Measure>(k));
    ASSERT_NEAR(g.extreme(Measure::ScaledJacobian), x, 1e-12);
    ++tried;
    TetMesh m2 = m0;
    const TetMesh before = m0;
    const InvariantSnapshot snap = capture_invariants(m0);
    TopoOptions o;
    o.guard = &g;
    TopoResult r;
    {
      TopoEditor ed(m2, o);
      r = ed.insert_vertex(t);
      ed.finish();
    }
    if (r != TopoResult::Applied) continue;
    ++found;
    ASSERT_EQ(m2.nv(), nv + 1);
    double sj = INFINITY;
    for (int32_t k = 0; k < m2.nt(); ++k) {
      const int32_t* v = m2.tet(k);
      if (v[0] == nv || v[1] == nv || v[2] == nv || v[3] == nv)
        sj = std::min(sj, scaled_jacobian(m2.point(v[0]), m2.point(v[1]), m2.point(v[2]), m2.point(v[3])));
    }
    EXPECT_GE(sj, x) << "seed " << seed;
    EXPECT_GT(worst(m2), tet_alpha(before, t)) << "seed " << seed;
    const Status s = check_invariants(m2, snap);
    EXPECT_TRUE(s.ok()) << s.message;
  }
  EXPECT_GE(tried, 2);
  EXPECT_GE(found, 2);
}
