// Boundary-preservation invariants (see invariants.hpp).
#include "tetopt/invariants.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "detail/edge_key.hpp"
#include "detail/parallel.hpp"
#include "tetopt/predicates.hpp"

namespace tetopt {

namespace {
std::vector<std::array<int32_t, 5>> constrained_faces(const TetMesh& m, int threads) {
  using Key = std::array<int32_t, 5>;
  // Per block of tets, each sorted, then merged in pairs (in parallel, level
  // by level): the list one std::sort of all of them gave (equal keys are
  // equal arrays), without that sort's serial 6 ms a call on the impeller.
  std::vector<std::vector<Key>> parts = detail::parallel_map_blocks(m.nt(), threads, [&](int64_t b, int64_t e) {
    std::vector<Key> found;
    for (auto t = static_cast<int32_t>(b); t < e; ++t)
      for (int f = 0; f < 4; ++f) {
        if (!(m.face_mask[t] >> f & 1)) continue;
        const int32_t n = m.adj[4 * t + f];
        // An interior constrained face is seen from both sides: keep it
        // once, from the side with the smaller (ref, tet) so refs are ordered.
        if (n >= 0) {
          const int32_t r0 = m.tet_ref[t], r1 = m.tet_ref[n / 4];
          if (r0 > r1 || (r0 == r1 && t > n / 4)) continue;
        }
        Key k{};
        face_key(m, t, f, k.data());
        k[3] = m.tet_ref[t];
        k[4] = n >= 0 ? m.tet_ref[n / 4] : -1;
        found.push_back(k);
      }
    std::sort(found.begin(), found.end());
    return found;
  });
  while (parts.size() > 1) {
    std::vector<std::vector<Key>> next((parts.size() + 1) / 2);
    detail::parallel_items(static_cast<int64_t>(next.size()), threads, [&](int64_t i) {
      const size_t a = 2 * static_cast<size_t>(i), b = a + 1;
      if (b == parts.size()) {
        next[static_cast<size_t>(i)] = std::move(parts[a]);
        return;
      }
      std::vector<Key>& o = next[static_cast<size_t>(i)];
      o.resize(parts[a].size() + parts[b].size());
      std::merge(parts[a].begin(), parts[a].end(), parts[b].begin(), parts[b].end(), o.begin());
    });
    parts.swap(next);
  }
  return parts.empty() ? std::vector<Key>{} : std::move(parts[0]);
}
// Ids (ascending) of the listed edges that are an edge of some tet.  Only
// tets with two listed-edge endpoints are looked at, and no vertex stars are
// needed (they may be stale after topology passes, see TopoOptions).
std::vector<int32_t> listed_edges_in_mesh(const TetMesh& m, int threads) {
  std::vector<int32_t> found;
  const size_t ne = m.edges.size() / 2;
  if (ne == 0) return found;
  std::vector<uint8_t> end(static_cast<size_t>(m.nv()), 0);
  for (int32_t v : m.edges)
    if (v >= 0 && v < m.nv()) end[v] = 1;
  const auto key = detail::edge_key;
  std::vector<std::pair<uint64_t, int32_t>> keys(ne);
  for (size_t i = 0; i < ne; ++i) keys[i] = {key(m.edges[2 * i], m.edges[2 * i + 1]), static_cast<int32_t>(i)};
  std::sort(keys.begin(), keys.end());
  const std::vector<int32_t> near = detail::parallel_select(m.nt(), threads, [&](int64_t t) {
    const int32_t* v = m.tet(static_cast<int32_t>(t));
    return end[v[0]] + end[v[1]] + end[v[2]] + end[v[3]] >= 2;
  });
  std::vector<uint8_t> hit(ne, 0);
  for (int32_t t : near) {
    const int32_t* v = m.tet(t);
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) {
        if (!end[v[i]] || !end[v[j]]) continue;
        const uint64_t k = key(v[i], v[j]);
        for (auto it = std::lower_bound(keys.begin(), keys.end(), std::make_pair(k, int32_t{-1}));
             it != keys.end() && it->first == k; ++it)
          hit[static_cast<size_t>(it->second)] = 1;
      }
  }
  for (size_t i = 0; i < ne; ++i)
    if (hit[i]) found.push_back(static_cast<int32_t>(i));
  return found;
}
}  // namespace

namespace {
// True when orient3d(a,b,c,d) is certainly Positive: the floating-point
// determinant exceeds Shewchuk's static error bound for orient3d
// (o3derrboundA = (7 + 56 eps) eps times the permanent; Shewchuk 1997,
// "Adaptive precision floating-point arithmetic and fast robust geometric
// predicates").  Undecided cases go to the exact predicate, so the answer is
// always exact; the filter only makes the common case cheap (the check must
// cost little next to the run).
bool surely_positive(const double* a, const double* b, const double* c, const double* d) {
  const double adx = a[0] - d[0], bdx = b[0] - d[0], cdx = c[0] - d[0];
  const double ady = a[1] - d[1], bdy = b[1] - d[1], cdy = c[1] - d[1];
  const double adz = a[2] - d[2], bdz = b[2] - d[2], cdz = c[2] - d[2];
  const double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
  const double cdxady = cdx * ady, adxcdy = adx * cdy;
  const double adxbdy = adx * bdy, bdxady = bdx * ady;
  // det[a-d; b-d; c-d] = -det[b-a; c-a; d-a] (orient3d's sign convention).
  const double det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
  const double perm = (std::fabs(bdxcdy) + std::fabs(cdxbdy)) * std::fabs(adz) +
                      (std::fabs(cdxady) + std::fabs(adxcdy)) * std::fabs(bdz) +
                      (std::fabs(adxbdy) + std::fabs(bdxady)) * std::fabs(cdz);
  constexpr double eps = 1.1102230246251565e-16;  // 2^-53
  constexpr double bound = (7.0 + 56.0 * eps) * eps;
  return -det > bound * perm;
}
}  // namespace

std::vector<int32_t> nonpositive_tets(const TetMesh& m, int threads) {
  return detail::parallel_select(m.nt(), threads, [&](int64_t t) {
    const int32_t* v = m.tet(static_cast<int32_t>(t));
    const double *a = m.point(v[0]), *b = m.point(v[1]), *c = m.point(v[2]), *d = m.point(v[3]);
    return !surely_positive(a, b, c, d) && orient3d(a, b, c, d) != Sign::Positive;
  });
}

InvariantSnapshot capture_invariants(const TetMesh& m, int threads) {
  InvariantSnapshot s;
  s.nv = m.nv();
  for (int32_t v = 0; v < m.nv(); ++v)
    if (m.vert_constrained[v]) {
      s.vertices.push_back(v);
      s.coords.insert(s.coords.end(), m.point(v), m.point(v) + 3);
    }
  s.faces = constrained_faces(m, threads);
  s.region_volume = region_volumes(m, threads);
  s.tris = m.tris;
  s.tri_ref = m.tri_ref;
  s.edges = m.edges;
  s.edge_ref = m.edge_ref;
  s.edges_in_mesh = listed_edges_in_mesh(m, threads);
  const std::vector<int32_t> bad = nonpositive_tets(m, threads);
  s.nonpositive = static_cast<int64_t>(bad.size());
  for (int32_t t : bad) s.tangled_vertices.insert(s.tangled_vertices.end(), m.tet(t), m.tet(t) + 4);
  std::sort(s.tangled_vertices.begin(), s.tangled_vertices.end());
  s.tangled_vertices.erase(std::unique(s.tangled_vertices.begin(), s.tangled_vertices.end()),
                           s.tangled_vertices.end());
  return s;
}

Status check_invariants(const TetMesh& m, const InvariantSnapshot& b, int threads) {
  auto fail = [](const std::string& what) { return Status::error(ErrorCode::Invariant, what); };
  // Vertex insertion (insert.hpp) appends free vertices: the original ids keep
  // their meaning, so only a shrinking count or a constrained newcomer fails.
  if (m.nv() < b.nv) return fail("vertex count changed from " + std::to_string(b.nv) + " to " + std::to_string(m.nv()));
  if (m.vert_constrained.size() == static_cast<size_t>(m.nv()))
    for (int32_t v = b.nv; v < m.nv(); ++v)
      if (m.vert_constrained[v]) return fail("appended vertex " + std::to_string(v + 1) + " is constrained");
  for (size_t i = 0; i < b.vertices.size(); ++i)
    if (std::memcmp(m.point(b.vertices[i]), &b.coords[3 * i], 3 * sizeof(double)) != 0)
      return fail("constrained vertex " + std::to_string(b.vertices[i] + 1) + " moved");
  if (m.tris != b.tris || m.tri_ref != b.tri_ref) return fail("listed boundary triangles or their refs changed");
  if (m.edges != b.edges || m.edge_ref != b.edge_ref) return fail("listed edges or their refs changed");
  if (!b.edges_in_mesh.empty()) {
    const std::vector<int32_t> now = listed_edges_in_mesh(m, threads);
    for (int32_t e : b.edges_in_mesh)
      if (!std::binary_search(now.begin(), now.end(), e))
        return fail("listed edge " + std::to_string(e + 1) + " (vertices " + std::to_string(m.edges[2 * e] + 1) + " " +
                    std::to_string(m.edges[2 * e + 1] + 1) + ") is no longer an edge of the mesh");
  }
  // Orientation: no tet may become inverted or flat outside the input's own
  // tangles, and their number may not grow (see the header).
  const std::vector<int32_t> bad = nonpositive_tets(m, threads);
  const auto tangled = [&](int32_t v) {
    return std::binary_search(b.tangled_vertices.begin(), b.tangled_vertices.end(), v);
  };
  for (int32_t t : bad) {
    const int32_t* v = m.tet(t);
    if (!tangled(v[0]) || !tangled(v[1]) || !tangled(v[2]) || !tangled(v[3]))
      return fail("tetrahedron " + std::to_string(t + 1) + " is inverted or flat" +
                  (b.nonpositive ? " (outside the input's inverted tets)" : ""));
  }
  if (static_cast<int64_t>(bad.size()) > b.nonpositive)
    return fail("inverted or flat tets grew from " + std::to_string(b.nonpositive) + " to " +
                std::to_string(bad.size()));
  const auto faces = constrained_faces(m, threads);
  if (faces != b.faces) {
    size_t lost = 0;
    for (const auto& f : b.faces) lost += !std::binary_search(faces.begin(), faces.end(), f);
    return fail("constrained faces changed: " + std::to_string(lost) + " of " + std::to_string(b.faces.size()) +
                " lost, " + std::to_string(faces.size() + lost - b.faces.size()) + " new");
  }
  const auto vol = region_volumes(m, threads);
  double total = 0;
  for (const auto& rv : b.region_volume) total += std::fabs(rv.second);
  if (vol.size() != b.region_volume.size()) return fail("the set of regions changed");
  for (size_t i = 0; i < vol.size(); ++i)
    if (vol[i].first != b.region_volume[i].first ||
        std::fabs(vol[i].second - b.region_volume[i].second) > 1e-9 * total)
      return fail("volume of region " + std::to_string(b.region_volume[i].first) + " changed");
  return Status::success();
}

}  // namespace tetopt
