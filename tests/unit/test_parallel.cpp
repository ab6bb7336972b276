// The parallel loops (src/detail/parallel.hpp) must give the same answer for
// every thread count: topology, classification, statistics, the first error
// of a bad mesh, and a whole improve() run.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <numeric>
#include <set>

#include "detail/parallel.hpp"
#include "tetopt/conventions.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/improve.hpp"
#include "tetopt/invariants.hpp"
#include "tetopt/io.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/topo.hpp"

using namespace tetopt;

namespace {

// 20 x 12 x 12 cells, 6 tets each: 17,280 tets, three blocks of the loops.
TetMesh jittered_box(int regions = 2) {
  BoxMeshOptions o;
  o.nx = 20;
  o.ny = 12;
  o.nz = 12;
  o.jitter = 0.3;
  o.seed = 7;
  o.regions = regions;
  return make_box_mesh(o);
}

bool same_double(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

}  // namespace

TEST(Parallel, BlocksCoverTheRangeOnce) {
  for (int64_t n : {int64_t{0}, int64_t{1}, detail::kBlock - 1, detail::kBlock, 3 * detail::kBlock + 5}) {
    std::vector<int> hits(static_cast<size_t>(n), 0);
    detail::parallel_for_each(n, 4, [&](int64_t i) { hits[static_cast<size_t>(i)]++; });
    for (int h : hits) ASSERT_EQ(h, 1);
    const int64_t sum = detail::parallel_reduce_blocks(
        n, 3, int64_t{0},
        [](int64_t b, int64_t e) {
          int64_t s = 0;
          for (int64_t i = b; i < e; ++i) s += i;
          return s;
        },
        [](int64_t x, int64_t y) { return x + y; });
    EXPECT_EQ(sum, n * (n - 1) / 2);
    // Ranges of any length (parallel_ranges, for maps over few heavy items).
    for (int64_t block : {int64_t{1}, int64_t{7}, int64_t{512}}) {
      std::vector<int> seen(static_cast<size_t>(n), 0);
      detail::parallel_ranges(n, block, 3, [&](int64_t b, int64_t e) {
        EXPECT_TRUE(b < e && e - b <= block && (b % block) == 0);
        for (int64_t i = b; i < e; ++i) seen[static_cast<size_t>(i)]++;
      });
      for (int h : seen) ASSERT_EQ(h, 1) << "block " << block;
    }
  }
}

TEST(Parallel, TopologyIsTheSameForEveryThreadCount) {
  TetMesh a = jittered_box(), b = jittered_box();
  ASSERT_GT(a.nt(), 2 * detail::kBlock);
  ASSERT_TRUE(build_topology(a, 1));
  ASSERT_TRUE(build_topology(b, 4));
  EXPECT_EQ(a.adj, b.adj);
  EXPECT_EQ(a.face_mask, b.face_mask);
  EXPECT_EQ(a.vert_constrained, b.vert_constrained);
  EXPECT_EQ(a.tet_kind, b.tet_kind);
  EXPECT_TRUE(validate(b, ValidateLevel::Full));
  // The region interface (x = 10) and the outer boundary are constrained.
  int64_t constrained = 0;
  for (uint8_t c : b.vert_constrained) constrained += c;
  EXPECT_GT(constrained, 0);
  EXPECT_LT(constrained, b.nv());
}

// The vertex->tet CSR is built from per-part counts when threads > 1
// (mesh.cpp, star_csr): every star must still list exactly the tets holding
// the vertex, in ascending order, for every thread count (four parts per
// thread, at most as many as tets per vertex: about 5 parts of uneven tet ranges
// here).
TEST(Parallel, VertexStarsAreTheSerialOnesForEveryThreadCount) {
  TetMesh ref = jittered_box();
  ASSERT_GE(ref.tets.size(), size_t{1} << 16);  // large enough for the parallel path
  build_vertex_tets(ref, 1);
  // Independent: the stars from a plain scan.
  std::vector<std::vector<int32_t>> star(static_cast<size_t>(ref.nv()));
  for (int32_t t = 0; t < ref.nt(); ++t)
    for (int k = 0; k < 4; ++k) star[ref.tets[4 * static_cast<size_t>(t) + k]].push_back(t);
  for (int32_t v = 0; v < ref.nv(); ++v)
    ASSERT_EQ(std::vector<int32_t>(ref.star_begin(v), ref.star_end(v)), star[v]) << v;
  for (int threads : {2, 3, 4, 0}) {
    TetMesh m = jittered_box();
    build_vertex_tets(m, threads);
    EXPECT_EQ(m.vt_offsets, ref.vt_offsets) << threads;
    EXPECT_EQ(m.vt_tets, ref.vt_tets) << threads;
  }
}

// tri_keys (built by classify) are the listed triangles, each sorted, in
// lexicographic order; compact_vertices renumbers them and keeps the order.
TEST(Parallel, TriangleKeysFollowTheListedTriangles) {
  TetMesh m = jittered_box();
  ASSERT_TRUE(build_topology(m, 2));
  ASSERT_GT(m.ntri(), 0);
  auto expected = [](const TetMesh& x) {
    std::vector<std::array<int32_t, 3>> k;
    for (int32_t i = 0; i < x.ntri(); ++i) {
      std::array<int32_t, 3> t{x.tris[3 * i], x.tris[3 * i + 1], x.tris[3 * i + 2]};
      std::sort(t.begin(), t.end());
      k.push_back(t);
    }
    std::sort(k.begin(), k.end());
    std::vector<int32_t> flat;
    for (const auto& t : k) flat.insert(flat.end(), t.begin(), t.end());
    return flat;
  };
  EXPECT_EQ(m.tri_keys, expected(m));
  // A copy with an extra unused vertex 0 (every other id one higher) must
  // compact back to the original ids, tri_keys included.
  TetMesh n = m;
  n.xyz.insert(n.xyz.begin(), {9.0, 9.0, 9.0});  // new vertex 0, every id + 1
  for (auto* ids : {&n.tets, &n.tris, &n.edges, &n.required_vertices, &n.corners, &n.tri_keys})
    for (int32_t& v : *ids) ++v;
  if (!n.vert_ref.empty()) n.vert_ref.insert(n.vert_ref.begin(), 0);
  if (!n.vert_constrained.empty()) n.vert_constrained.insert(n.vert_constrained.begin(), 0);
  n.vt_offsets.clear();
  ASSERT_TRUE(compact_vertices(n, {0}));
  EXPECT_EQ(n.tris, m.tris);
  EXPECT_EQ(n.tri_keys, m.tri_keys);
}

// The invariant proof scans tets in parallel blocks: the snapshot (faces,
// region volumes to the bit, inverted tets) and the verdicts must be the
// serial ones for every thread count.
TEST(Parallel, InvariantProofIsTheSameForEveryThreadCount) {
  TetMesh m = jittered_box(2);
  ASSERT_TRUE(build_topology(m, 1));
  // Invert two tets in different blocks by swapping two vertices (the
  // connectivity is unchanged, only their orientation).
  for (int32_t t : {int32_t{5}, int32_t{2 * detail::kBlock + 7}}) std::swap(m.tets[4 * t], m.tets[4 * t + 1]);
  const InvariantSnapshot ref = capture_invariants(m, 1);
  ASSERT_EQ(ref.nonpositive, 2);
  ASSERT_EQ(ref.region_volume.size(), 2u);
  // The constrained faces, found here by a plain scan: every face of the
  // outer boundary and of the region interface, once, sorted.
  {
    std::set<std::array<int32_t, 5>> plain;
    for (int32_t t = 0; t < m.nt(); ++t)
      for (int f = 0; f < 4; ++f) {
        const int32_t n = m.adj[4 * static_cast<size_t>(t) + f];
        if (n >= 0 && m.tet_ref[n / 4] == m.tet_ref[t]) continue;
        std::array<int32_t, 3> v{};
        for (int k = 0; k < 3; ++k) v[k] = m.tets[4 * static_cast<size_t>(t) + kFaceVertex[f][k]];
        std::sort(v.begin(), v.end());
        const int32_t r0 = m.tet_ref[t], r1 = n >= 0 ? m.tet_ref[n / 4] : -1;
        if (n >= 0 && r0 > r1) continue;  // kept from the side with the smaller ref
        plain.insert({v[0], v[1], v[2], r0, r1});
      }
    ASSERT_GT(plain.size(), 1000u);
    const std::vector<std::array<int32_t, 5>> want(plain.begin(), plain.end());
    EXPECT_EQ(ref.faces, want);
  }
  for (int threads : {2, 3, 0}) {
    const InvariantSnapshot s = capture_invariants(m, threads);
    EXPECT_EQ(s.faces, ref.faces) << threads;
    ASSERT_EQ(s.region_volume.size(), ref.region_volume.size());
    for (size_t i = 0; i < s.region_volume.size(); ++i) {
      EXPECT_EQ(s.region_volume[i].first, ref.region_volume[i].first);
      EXPECT_TRUE(same_double(s.region_volume[i].second, ref.region_volume[i].second)) << threads;
    }
    EXPECT_EQ(s.tangled_vertices, ref.tangled_vertices) << threads;
    EXPECT_EQ(nonpositive_tets(m, threads), nonpositive_tets(m, 1)) << threads;
    EXPECT_TRUE(check_invariants(m, ref, threads)) << threads;
  }
  // A moved constrained vertex and a third inverted tet fail at every count.
  TetMesh moved = m;
  int32_t v = 0;
  while (!moved.vert_constrained[v]) ++v;
  moved.xyz[3 * static_cast<size_t>(v)] += 1e-3;
  TetMesh flipped = m;
  const int32_t t3 = 3 * detail::kBlock / 2;
  std::swap(flipped.tets[4 * t3], flipped.tets[4 * t3 + 1]);
  for (int threads : {1, 2, 3}) {
    EXPECT_FALSE(check_invariants(moved, ref, threads)) << threads;
    const Status s = check_invariants(flipped, ref, threads);
    EXPECT_FALSE(s) << threads;
    EXPECT_NE(s.message.find("inverted or flat"), std::string::npos) << s.message;
  }
}

TEST(Parallel, FirstErrorIsTheSerialOne) {
  // Two defects far apart (different blocks): a duplicated tet near the end
  // and a third tet on an early face.  Every thread count names the same one.
  TetMesh base = jittered_box(1);
  const int32_t late = base.nt() - 3, early = 5;
  for (int k = 0; k < 4; ++k) base.tets.push_back(base.tets[4 * static_cast<size_t>(late) + k]);
  base.tet_ref.push_back(base.tet_ref[late]);
  // A third tet on an interior face of tet `early`, apex off to the side.
  TetMesh probe = jittered_box(1);
  ASSERT_TRUE(build_topology(probe));
  int face = -1;
  for (int f = 0; f < 4 && face < 0; ++f)
    if (probe.adj[4 * early + f] >= 0) face = f;
  ASSERT_GE(face, 0);
  const int32_t* v = base.tet(early);
  const int32_t f0 = v[kFaceVertex[face][0]], f1 = v[kFaceVertex[face][1]], f2 = v[kFaceVertex[face][2]];
  base.xyz.insert(base.xyz.end(), {-5.0, -5.0, -5.0});
  const int32_t apex = base.nv() - 1;
  base.tets.insert(base.tets.end(), {f0, f1, f2, apex});
  base.tet_ref.push_back(base.tet_ref[early]);
  std::string msg1;
  for (int threads : {1, 2, 4}) {
    TetMesh m = base;
    const Status s = build_topology(m, threads);
    ASSERT_FALSE(s);
    if (threads == 1) msg1 = s.message;
    EXPECT_EQ(s.message, msg1) << threads << " threads";
  }
  EXPECT_NE(msg1.find("not manifold"), std::string::npos) << msg1;
}

TEST(Parallel, StatisticsAreTheSameForEveryThreadCount) {
  TetMesh m = jittered_box();
  ASSERT_TRUE(build_topology(m));
  const QualityStats a = compute_stats(m, 1), b = compute_stats(m, 3);
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.regions, 2);
  EXPECT_EQ(a.regions, b.regions);
  EXPECT_EQ(a.worst_tet, b.worst_tet);
  for (int k = 0; k < 5; ++k) EXPECT_EQ(a.kind_count[k], b.kind_count[k]);
  EXPECT_EQ(a.alpha_histogram, b.alpha_histogram);
  EXPECT_EQ(a.dihedral_histogram, b.dihedral_histogram);
  for (auto [x, y] : {std::pair{a.alpha_worst, b.alpha_worst}, {a.alpha_mean, b.alpha_mean},
                      {a.alpha_boundary_mean, b.alpha_boundary_mean}, {a.alpha_interior_mean, b.alpha_interior_mean},
                      {a.dihedral_min, b.dihedral_min}, {a.dihedral_max, b.dihedral_max},
                      {a.mean_ratio_worst, b.mean_ratio_worst}, {a.radius_ratio_worst, b.radius_ratio_worst}})
    EXPECT_TRUE(same_double(x, y)) << x << " vs " << y;
  // And they are the statistics: the worst alpha is that of worst_tet, the
  // mean agrees with a plain sum.
  EXPECT_EQ(a.alpha_worst, tet_alpha(m, a.worst_tet));
  double sum = 0;
  for (int32_t t = 0; t < m.nt(); ++t) sum += tet_alpha(m, t);
  EXPECT_NEAR(a.alpha_mean, sum / m.nt(), 1e-12);
}

TEST(Parallel, ImproveIsByteIdenticalForEveryThreadCount) {
  TetMesh base = jittered_box();
  ASSERT_TRUE(build_topology(base));
  std::vector<TetMesh> out;
  for (int threads : {1, 2, 4}) {
    TetMesh m = base;
    ImproveOptions o;
    o.threads = threads;
    ImproveReport r;
    ASSERT_TRUE(improve(m, o, r));
    EXPECT_TRUE(r.invariants_ok);
    EXPECT_GT(r.after.alpha_worst, r.before.alpha_worst);
    out.push_back(std::move(m));
  }
  for (size_t i = 1; i < out.size(); ++i) {
    ASSERT_EQ(out[i].xyz.size(), out[0].xyz.size());
    EXPECT_EQ(std::memcmp(out[i].xyz.data(), out[0].xyz.data(), out[0].xyz.size() * sizeof(double)), 0);
    EXPECT_EQ(out[i].tets, out[0].tets);
    EXPECT_EQ(out[i].tet_ref, out[0].tet_ref);
  }
}

TEST(Parallel, MeditWriterGivesTheSameBytes) {
  TetMesh m = jittered_box();
  ASSERT_GT(m.nv(), static_cast<int32_t>(detail::kBlock) / 4);
  std::string a, b;
  ASSERT_TRUE(format_medit(m, a, 1));
  ASSERT_TRUE(format_medit(m, b, 3));
  EXPECT_EQ(a, b);
  // And it reads back to the same mesh.
  TetMesh back;
  ASSERT_TRUE(parse_medit(b, "parallel.mesh", back));
  EXPECT_EQ(back.tets, m.tets);
  ASSERT_EQ(back.xyz.size(), m.xyz.size());
  EXPECT_EQ(std::memcmp(back.xyz.data(), m.xyz.data(), m.xyz.size() * sizeof(double)), 0);
}

// The flip passes plan windows of 512 tets in parallel and commit in order
// (TopoEditor::improve_tets).  A pass with thousands of operations, many of
// them next to each other (so plans are invalidated and redone), must give
// the serial pass's mesh and counts for every thread count, and keep the
// promise (constrained vertices and faces, no inverted tet, region volumes).
TEST(Parallel, FlipPassesAreTheSerialOnesForEveryThreadCount) {
  TetMesh base = jittered_box();
  ASSERT_TRUE(build_topology(base));
  const InvariantSnapshot snap = capture_invariants(base);
  std::vector<TetMesh> out;
  std::vector<TopoStats> stats;
  for (int threads : {1, 2, 4}) {
    TetMesh m = base;
    TopoOptions o;
    o.threads = threads;
    o.quality_threshold = 0.7;  // most tets of the jittered box: long work lists
    TopoStats st = remove_all_boundary_tets(m, o, {});
    ASSERT_TRUE(st.status);
    TopoStats fp = flip_pass(m, o, {});
    ASSERT_TRUE(fp.status);
    st.flip32 += fp.flip32;
    st.flip23 += fp.flip23;
    st.flip44 += fp.flip44;
    st.edge_removals += fp.edge_removals;
    st.multi_face_removals += fp.multi_face_removals;
    ASSERT_TRUE(check_invariants(m, snap)) << "threads " << threads;
    out.push_back(std::move(m));
    stats.push_back(st);
  }
  EXPECT_GT(stats[0].flip32 + stats[0].flip23 + stats[0].multi_face_removals + stats[0].edge_removals, 1000);
  for (size_t i = 1; i < out.size(); ++i) {
    EXPECT_EQ(out[i].tets, out[0].tets);
    EXPECT_EQ(out[i].adj, out[0].adj);
    EXPECT_EQ(out[i].face_mask, out[0].face_mask);
    EXPECT_EQ(stats[i].flip32, stats[0].flip32);
    EXPECT_EQ(stats[i].flip23, stats[0].flip23);
    EXPECT_EQ(stats[i].flip44, stats[0].flip44);
    EXPECT_EQ(stats[i].multi_face_removals, stats[0].multi_face_removals);
    EXPECT_EQ(stats[i].all_boundary_removed, stats[0].all_boundary_removed);
  }
}

// check_arrays and normalize_orientation scan in parallel blocks: the error
// reported is the first in index order, and the orientation report (counts,
// ids, flip) is the serial one, for every thread count.
TEST(Parallel, ReaderChecksAreTheSerialOnes) {
  TetMesh base = jittered_box();
  BoxMeshOptions wo;
  wo.nx = wo.ny = 30;
  wo.nz = 12;
  const TetMesh wide = make_box_mesh(wo);
  for (int threads : {1, 2, 4}) {
    TetMesh m = base;
    // Two bad tets far apart (different blocks): the first must be named.
    m.tets[4 * 15000 + 1] = m.tets[4 * 15000];
    m.tets[4 * 20 + 2] = m.nv() + 5;
    const Status s = check_arrays(m, "x", threads);
    EXPECT_EQ(s.message, "x: tetrahedron 21 names vertex " + std::to_string(m.nv() + 6) + ", outside 1.." +
                             std::to_string(m.nv()))
        << threads;
    // Two bad vertices in different blocks of 8192 (the box has 12,493).
    TetMesh n = wide;
    ASSERT_GT(n.nv(), 12001);
    n.xyz[3 * 12000 + 1] = std::nan("");
    n.xyz[3 * 9 + 2] = INFINITY;
    EXPECT_EQ(check_arrays(n, "x", threads).message, "x: vertex 10 has a NaN or infinite coordinate");
  }
  // Orientation: flip every tet but a few; the report and the mesh must not
  // depend on the thread count.
  TetMesh neg = base;
  for (int32_t t = 0; t < neg.nt(); ++t)
    if (t % 997 != 3) std::swap(neg.tets[4 * t + kFlipA], neg.tets[4 * t + kFlipB]);
  TetMesh a = neg, b = neg;
  const OrientationReport ra = normalize_orientation(a, 1), rb = normalize_orientation(b, 2);
  EXPECT_TRUE(ra.flipped);
  EXPECT_GT(ra.inverted.size(), 0u);
  EXPECT_EQ(ra.positive, rb.positive);
  EXPECT_EQ(ra.negative, rb.negative);
  EXPECT_EQ(ra.flat, rb.flat);
  EXPECT_EQ(ra.inverted, rb.inverted);
  EXPECT_EQ(ra.flipped, rb.flipped);
  EXPECT_EQ(a.tets, b.tets);
}

// build_topology finds face neighbours in the vertex stars and listed
// triangles through the star of their first vertex; build_adjacency_sorted
// (a global bucket sort, validate()'s independent rebuild) and a map of
// sorted face keys here must agree with it, for every thread count, on a
// shuffled mesh (so stars are not in tet order by construction) with
// interior listed triangles, two regions and boundary faces.
TEST(Parallel, StarAdjacencyAndClassifyMatchIndependentMethods) {
  TetMesh base = jittered_box(2);
  // Shuffle tets (and their refs) so tet ids are not spatially ordered.
  const int32_t nt = base.nt();
  std::vector<int32_t> order(static_cast<size_t>(nt));
  for (int32_t t = 0; t < nt; ++t) order[t] = static_cast<int32_t>((static_cast<int64_t>(t) * 7919) % nt);
  ASSERT_EQ(std::gcd(7919, nt), 1);
  TetMesh sh = base;
  for (int32_t t = 0; t < nt; ++t) {
    std::copy(base.tet(order[t]), base.tet(order[t]) + 4, &sh.tets[4 * static_cast<size_t>(t)]);
    sh.tet_ref[t] = base.tet_ref[order[t]];
  }
  // List 300 interior faces (both sides in one region) as triangles.
  ASSERT_TRUE(build_topology(sh, 1));
  sh.tris.clear();
  sh.tri_ref.clear();
  for (int32_t t = 0; t < nt && sh.ntri() < 300; t += 37)
    for (int f = 0; f < 4; ++f) {
      const int32_t n = sh.adj[4 * t + f];
      if (n >= 0 && sh.tet_ref[n / 4] == sh.tet_ref[t]) {
        const int32_t* v = sh.tet(t);
        sh.tris.insert(sh.tris.end(), {v[kFaceVertex[f][2]], v[kFaceVertex[f][0]], v[kFaceVertex[f][1]]});
        sh.tri_ref.push_back(9);
        break;
      }
    }
  ASSERT_EQ(sh.ntri(), 300);
  // Independent reference: every face by sorted key.
  std::map<std::array<int32_t, 3>, std::vector<int32_t>> faces;
  for (int32_t t = 0; t < nt; ++t)
    for (int f = 0; f < 4; ++f) {
      std::array<int32_t, 3> k{};
      face_key(sh, t, f, k.data());
      faces[k].push_back(4 * t + f);
    }
  std::set<std::array<int32_t, 3>> listed;
  for (int32_t i = 0; i < sh.ntri(); ++i) {
    std::array<int32_t, 3> k{sh.tris[3 * i], sh.tris[3 * i + 1], sh.tris[3 * i + 2]};
    std::sort(k.begin(), k.end());
    listed.insert(k);
  }
  std::vector<int32_t> adj_ref(4 * static_cast<size_t>(nt), -1);
  std::vector<uint8_t> mask_ref(static_cast<size_t>(nt), 0);
  int64_t listed_faces = 0;
  for (const auto& [k, fs] : faces) {
    ASSERT_LE(fs.size(), 2u);
    if (fs.size() == 2) { adj_ref[fs[0]] = fs[1]; adj_ref[fs[1]] = fs[0]; }
    const bool is_listed = listed.count(k) > 0;
    listed_faces += is_listed ? static_cast<int64_t>(fs.size()) : 0;
    for (int32_t x : fs) {
      const int32_t n = fs.size() == 2 ? (fs[0] == x ? fs[1] : fs[0]) : -1;
      if (n < 0 || sh.tet_ref[n / 4] != sh.tet_ref[x / 4] || is_listed) mask_ref[x / 4] |= static_cast<uint8_t>(1u << (x % 4));
    }
  }
  EXPECT_EQ(listed_faces, 600);  // every listed triangle is an interior face
  TetMesh sorted = sh;
  ASSERT_TRUE(build_adjacency_sorted(sorted, 1));
  EXPECT_EQ(sorted.adj, adj_ref);
  for (int threads : {1, 2, 3}) {
    TetMesh m = sh;
    ASSERT_TRUE(build_topology(m, threads));
    EXPECT_EQ(m.adj, adj_ref) << threads << " threads";
    EXPECT_EQ(m.face_mask, mask_ref) << threads << " threads";
    for (int32_t v = 0; v < m.nv(); ++v)  // stars in increasing tet order
      ASSERT_TRUE(std::is_sorted(m.star_begin(v), m.star_end(v)));
    TetMesh a = sh;
    ASSERT_TRUE(build_adjacency(a, threads));
    EXPECT_EQ(a.adj, adj_ref) << threads << " threads";
    EXPECT_TRUE(validate(m, ValidateLevel::Full)) << threads << " threads";
  }
}

// refresh_topology (tetopt-mpi's merge of later rounds): the tets inside a
// ball are replaced by the same tets in another order with their vertices
// rotated (an even permutation), the kept tets carry their links; the
// result must be build_topology's, array for array, for every thread count,
// with listed interior triangles and two regions.
TEST(Parallel, RefreshTopologyEqualsAFullRebuild) {
  TetMesh g = jittered_box(2);
  ASSERT_TRUE(build_topology(g, 1));
  // List some interior faces, inside and outside the ball, as triangles.
  for (int32_t t = 0; t < g.nt(); t += 13)
    for (int f = 0; f < 4; ++f) {
      const int32_t n = g.adj[4 * t + f];
      if (n >= 0 && g.tet_ref[n / 4] == g.tet_ref[t]) {
        const int32_t* v = g.tet(t);
        g.tris.insert(g.tris.end(), {v[kFaceVertex[f][0]], v[kFaceVertex[f][1]], v[kFaceVertex[f][2]]});
        g.tri_ref.push_back(5);
        break;
      }
    }
  ASSERT_TRUE(build_topology(g, 1));
  const int32_t nt = g.nt();
  std::vector<uint8_t> replaced(static_cast<size_t>(nt), 0);
  int32_t nrep = 0;
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (int32_t v = 0; v < g.nv(); ++v)
    for (int d = 0; d < 3; ++d) { lo[d] = std::min(lo[d], g.point(v)[d]); hi[d] = std::max(hi[d], g.point(v)[d]); }
  for (int32_t t = 0; t < nt; ++t) {
    double c[3] = {0, 0, 0};  // centroid in the box's unit coordinates
    for (int k = 0; k < 4; ++k)
      for (int d = 0; d < 3; ++d) c[d] += (g.point(g.tet(t)[k])[d] - lo[d]) / (hi[d] - lo[d]) / 4;
    const double r2 = (c[0] - 0.5) * (c[0] - 0.5) + (c[1] - 0.4) * (c[1] - 0.4) + (c[2] - 0.5) * (c[2] - 0.5);
    if (r2 < 0.09) { replaced[t] = 1; ++nrep; }
  }
  ASSERT_GT(nrep, 1000);
  ASSERT_LT(nrep, nt - 1000);
  int64_t listed_on_replaced = 0;  // listed faces with a replaced tet on a side
  for (int32_t t = 0; t < nt; ++t)
    if (replaced[t])
      for (int f = 0; f < 4; ++f)
        if (g.face_mask[t] & (1u << f)) listed_on_replaced += g.adj[4 * t + f] >= 0 && g.tet_ref[g.adj[4 * t + f] / 4] == g.tet_ref[t];
  ASSERT_GT(listed_on_replaced, 20);
  TetMesh m = g;
  m.tets.clear();
  m.tet_ref.clear();
  std::vector<int32_t> newid(static_cast<size_t>(nt), -1);
  int32_t nkept = 0;
  for (int32_t t = 0; t < nt; ++t)
    if (!replaced[t]) newid[t] = nkept++;
  m.adj.assign(4 * static_cast<size_t>(nkept), -1);
  m.face_mask.assign(static_cast<size_t>(nkept), 0);
  m.tet_kind.assign(static_cast<size_t>(nkept), 0);
  for (int32_t t = 0; t < nt; ++t) {
    if (replaced[t]) continue;
    m.tets.insert(m.tets.end(), g.tet(t), g.tet(t) + 4);
    m.tet_ref.push_back(g.tet_ref[t]);
    for (int f = 0; f < 4; ++f) {
      const int32_t a = g.adj[4 * t + f];
      m.adj[4 * static_cast<size_t>(newid[t]) + f] = a >= 0 && newid[a / 4] >= 0 ? 4 * newid[a / 4] + a % 4 : -1;
    }
    m.face_mask[newid[t]] = g.face_mask[t];
    m.tet_kind[newid[t]] = g.tet_kind[t];
  }
  for (int32_t t = nt - 1; t >= 0; --t) {  // replaced tets, reversed, (a,b,c,d) -> (b,c,a,d)
    if (!replaced[t]) continue;
    const int32_t* v = g.tet(t);
    m.tets.insert(m.tets.end(), {v[1], v[2], v[0], v[3]});
    m.tet_ref.push_back(g.tet_ref[t]);
  }
  TetMesh full = m;
  ASSERT_TRUE(build_topology(full, 1));
  for (int threads : {1, 2, 3}) {
    TetMesh r = m;
    const uint64_t epoch = r.topology_epoch;
    ASSERT_TRUE(refresh_topology(r, nkept, threads));
    EXPECT_EQ(r.adj, full.adj) << threads;
    EXPECT_EQ(r.face_mask, full.face_mask) << threads;
    EXPECT_EQ(r.tet_kind, full.tet_kind) << threads;
    EXPECT_EQ(r.vert_constrained, full.vert_constrained) << threads;
    EXPECT_EQ(r.vt_offsets, full.vt_offsets) << threads;
    EXPECT_EQ(r.vt_tets, full.vt_tets) << threads;
    EXPECT_NE(r.topology_epoch, epoch);
    EXPECT_TRUE(validate(r, ValidateLevel::Full));
  }
  // A kept link that does not close up (one-sided) falls back to the full
  // rebuild, with the same result.
  TetMesh bad = m;
  for (size_t x = 0; x < bad.adj.size(); ++x)
    if (bad.adj[x] >= 0) { bad.adj[x] = -1; break; }
  ASSERT_TRUE(refresh_topology(bad, nkept, 2));
  EXPECT_EQ(bad.adj, full.adj);
  EXPECT_EQ(bad.face_mask, full.face_mask);
}

// sort_tets_spatially permutes the tets with their refs and entities (a
// multiset check), keeps vertex ids and coordinates, gives the same order
// for every thread count, clears the stale topology, and puts tets near in
// space near in memory (mean centroid distance of consecutive tets drops
// on a shuffled box).
TEST(Parallel, SortTetsSpatiallyIsAPermutationTowardsLocality) {
  TetMesh base = jittered_box(2);
  const int32_t nt = base.nt();
  base.tet_entity.resize(static_cast<size_t>(nt));
  for (int32_t t = 0; t < nt; ++t) base.tet_entity[t] = t % 7;
  TetMesh sh = base;  // shuffled: tet t takes base tet (t * 7919) mod nt
  for (int32_t t = 0; t < nt; ++t) {
    const int32_t s = static_cast<int32_t>((static_cast<int64_t>(t) * 7919) % nt);
    std::copy(base.tet(s), base.tet(s) + 4, &sh.tets[4 * static_cast<size_t>(t)]);
    sh.tet_ref[t] = base.tet_ref[s];
    sh.tet_entity[t] = base.tet_entity[s];
  }
  auto records = [](const TetMesh& m) {
    std::vector<std::array<int32_t, 6>> r;
    for (int32_t t = 0; t < m.nt(); ++t)
      r.push_back({m.tet(t)[0], m.tet(t)[1], m.tet(t)[2], m.tet(t)[3], m.tet_ref[t], m.tet_entity[t]});
    std::sort(r.begin(), r.end());
    return r;
  };
  auto spread = [](const TetMesh& m) {  // mean distance between consecutive centroids
    double sum = 0, prev[3] = {0, 0, 0};
    for (int32_t t = 0; t < m.nt(); ++t) {
      double c[3] = {0, 0, 0};
      for (int k = 0; k < 4; ++k)
        for (int d = 0; d < 3; ++d) c[d] += m.point(m.tet(t)[k])[d] / 4;
      if (t > 0) sum += std::sqrt((c[0] - prev[0]) * (c[0] - prev[0]) + (c[1] - prev[1]) * (c[1] - prev[1]) +
                                  (c[2] - prev[2]) * (c[2] - prev[2]));
      std::copy(c, c + 3, prev);
    }
    return sum / (m.nt() - 1);
  };
  ASSERT_TRUE(build_topology(sh, 1));
  std::vector<int32_t> first;
  for (int threads : {1, 2, 3}) {
    TetMesh m = sh;
    sort_tets_spatially(m, threads);
    EXPECT_EQ(records(m), records(sh));
    EXPECT_EQ(m.xyz, sh.xyz);
    EXPECT_TRUE(m.adj.empty() && m.vt_tets.empty() && m.face_mask.empty());
    if (first.empty()) first = m.tets;
    EXPECT_EQ(m.tets, first) << threads << " threads";
    EXPECT_LT(spread(m), spread(sh) / 4);
    ASSERT_TRUE(build_topology(m, threads));
    EXPECT_TRUE(validate(m, ValidateLevel::Full));
  }
  // order[new] = old: a permutation that maps every sorted tet to its
  // record in the input.
  TetMesh m = sh;
  std::vector<int32_t> order;
  sort_tets_spatially(m, 2, &order);
  ASSERT_EQ(order.size(), static_cast<size_t>(nt));
  std::vector<int32_t> seen(order);
  std::sort(seen.begin(), seen.end());
  for (int32_t i = 0; i < nt; ++i) ASSERT_EQ(seen[i], i);
  for (int32_t t = 0; t < nt; ++t) {
    const int32_t o = order[t];
    EXPECT_TRUE(std::equal(m.tet(t), m.tet(t) + 4, sh.tet(o)) && m.tet_ref[t] == sh.tet_ref[o] &&
                m.tet_entity[t] == sh.tet_entity[o])
        << t;
  }
  EXPECT_EQ(m.tets, first);  // asking for the order does not change it
  // tet_order_spread: about 1 in a spatial order, far above the CLI's
  // threshold (tetopt_cli::kSortSpread = 8) when shuffled; the same value
  // for every thread count.
  const double in_order = tet_order_spread(base, 1), shuffled = tet_order_spread(sh, 1);
  EXPECT_LT(in_order, 2.0);
  EXPECT_GT(shuffled, 8.0);
  EXPECT_LT(tet_order_spread(m, 1), 2.0);
  for (int threads : {2, 3}) {
    EXPECT_EQ(tet_order_spread(sh, threads), shuffled);
    EXPECT_EQ(tet_order_spread(base, threads), in_order);
  }
}
