// What the HTML report's 3D view draws (see view3d.hpp).
#include "tetopt/view3d.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <unordered_map>

#include "detail/parallel.hpp"

#include "tetopt/conventions.hpp"
#include "tetopt/quality.hpp"

namespace tetopt {

namespace {

using Tri = std::array<int32_t, 3>;

Tri sorted(Tri t) {
  std::sort(t.begin(), t.end());
  return t;
}

// One boundary triangle before compaction: mesh vertex ids, outward, its ref.
struct Face {
  Tri v;
  int32_t ref;
};

// Vertex clustering (Rossignac and Borrel 1993) of the faces on a grid of
// `cells` cells along the bounding box's longest side: vertices in one cell
// merge, faces that collapse or repeat (same three clusters) are dropped.
// Returns the cluster id of every mesh vertex used (-1 elsewhere) and the
// kept faces over cluster ids.
struct Clustered {
  std::vector<int32_t> cluster_of;  // mesh vertex -> cluster
  int32_t clusters = 0;
  std::vector<Face> faces;          // over cluster ids
};

Clustered cluster(const TetMesh& m, const std::vector<Face>& faces, const double lo[3], double cell) {
  Clustered c;
  c.cluster_of.assign(static_cast<size_t>(m.nv()), -1);
  std::unordered_map<uint64_t, int32_t> cell_id;
  auto id_of = [&](int32_t v) {
    int32_t& slot = c.cluster_of[static_cast<size_t>(v)];
    if (slot >= 0) return slot;
    const double* p = m.point(v);
    uint64_t key = 0;
    for (int k = 0; k < 3; ++k) key = key << 21 | (static_cast<uint64_t>(std::floor((p[k] - lo[k]) / cell)) & 0x1fffff);
    auto [it, fresh] = cell_id.emplace(key, c.clusters);
    if (fresh) ++c.clusters;
    return slot = it->second;
  };
  std::unordered_map<uint64_t, char> seen;  // sorted cluster triple (21 bits each)
  for (const Face& f : faces) {
    const Tri t{id_of(f.v[0]), id_of(f.v[1]), id_of(f.v[2])};
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
    const Tri s = sorted(t);
    const uint64_t key = static_cast<uint64_t>(s[0]) << 42 | static_cast<uint64_t>(s[1]) << 21 |
                         static_cast<uint64_t>(s[2]);
    if (!seen.emplace(key, 1).second) continue;
    c.faces.push_back({t, f.ref});
  }
  return c;
}

}  // namespace

void view_origin(const TetMesh& m, double origin[3]) {
  double lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = std::numeric_limits<double>::infinity();
    hi[k] = -lo[k];
  }
  for (int32_t v = 0; v < m.nv(); ++v)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], m.point(v)[k]);
      hi[k] = std::max(hi[k], m.point(v)[k]);
    }
  for (int k = 0; k < 3; ++k) origin[k] = m.nv() > 0 ? 0.5 * (lo[k] + hi[k]) : 0.0;
}

ViewSurface view_surface(const TetMesh& m, size_t budget) {
  ViewSurface s;
  view_origin(m, s.origin);
  // Refs of the listed triangles by their sorted vertex triple.
  std::vector<std::pair<Tri, int32_t>> listed;
  listed.reserve(static_cast<size_t>(m.ntri()));
  for (int32_t i = 0; i < m.ntri(); ++i)
    listed.push_back({sorted({m.tris[3 * static_cast<size_t>(i)], m.tris[3 * static_cast<size_t>(i) + 1],
                              m.tris[3 * static_cast<size_t>(i) + 2]}),
                      i < static_cast<int32_t>(m.tri_ref.size()) ? m.tri_ref[static_cast<size_t>(i)] : 0});
  std::sort(listed.begin(), listed.end());
  s.by_patch = !listed.empty();
  std::vector<Face> faces;
  // Without face adjacency (build_topology not run) there is no boundary to
  // draw: an empty surface.
  const int32_t nt_adj = m.adj.size() == m.tets.size() ? m.nt() : 0;
  const bool masks = m.face_mask.size() == static_cast<size_t>(m.nt());
  auto region = [&](int32_t t) { return m.tet_ref.empty() ? 0 : m.tet_ref[static_cast<size_t>(t)]; };
  for (int32_t t = 0; t < nt_adj; ++t)
    for (int f = 0; f < 4; ++f) {
      // Every constrained face once: the boundary, and the interfaces and
      // listed triangles inside, taken from the side with the smaller region
      // ref (then the smaller tet id) and facing away from it.
      const int32_t nb = m.adj[4 * static_cast<size_t>(t) + static_cast<size_t>(f)];
      if (nb != -1) {
        if (!masks || !(m.face_mask[static_cast<size_t>(t)] >> f & 1)) continue;
        const int32_t u = nb >> 2;
        if (region(u) < region(t) || (region(u) == region(t) && u < t)) continue;
      }
      const int32_t* tv = m.tet(t);
      Tri v{tv[kFaceVertex[f][0]], tv[kFaceVertex[f][1]], tv[kFaceVertex[f][2]]};
      // Outward: the opposite vertex lies behind the face (display only, so
      // floating point suffices; a flat tet gives either order).
      const double *a = m.point(v[0]), *b = m.point(v[1]), *c = m.point(v[2]), *d = m.point(tv[f]);
      const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
      const double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
      if (n[0] * (d[0] - a[0]) + n[1] * (d[1] - a[1]) + n[2] * (d[2] - a[2]) > 0) std::swap(v[1], v[2]);
      int32_t ref = region(t);
      if (s.by_patch) {
        const Tri key = sorted(v);
        auto it = std::lower_bound(listed.begin(), listed.end(), std::make_pair(key, std::numeric_limits<int32_t>::min()));
        if (it != listed.end() && it->first == key) ref = it->second;
      }
      faces.push_back({v, ref});
    }
  s.triangles_full = static_cast<int64_t>(faces.size());

  // Bounding box of the surface, for the grid and the camera.
  double lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = std::numeric_limits<double>::infinity();
    hi[k] = -lo[k];
  }
  for (const Face& f : faces)
    for (int32_t v : f.v)
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], m.point(v)[k]);
        hi[k] = std::max(hi[k], m.point(v)[k]);
      }
  if (!faces.empty())
    s.bbox_diagonal = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                (hi[2] - lo[2]) * (hi[2] - lo[2]));

  // Vertex ids and faces to emit: the mesh's own, or clustered ones.
  std::vector<int32_t> vertex_of;  // emitted vertex -> mesh vertex (undecimated)
  std::vector<Face> out;
  std::vector<double> cluster_xyz;  // decimated: mean position of each cluster
  if (faces.size() > budget && budget > 0) {
    const double side = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-300});
    // A surface on an n-cell grid keeps about 2 triangles per surface cell,
    // so the count goes as n^2: start from the cell that would give the
    // budget on a cube's surface (12 n^2) and rescale n by the square root
    // of budget / count until the count lies in [0.85, 1] x budget (a few
    // passes; the finest grid within the budget is kept).
    double cells = std::min(1.0e6, std::sqrt(static_cast<double>(budget) / 12.0));
    Clustered c, best;
    bool have = false;
    for (int iter = 0; iter < 40; ++iter) {
      c = cluster(m, faces, lo, side / cells * (1 + 1e-9));
      const double ratio = static_cast<double>(budget) / static_cast<double>(std::max<size_t>(1, c.faces.size()));
      if (c.faces.size() <= budget) {
        if (!have || c.faces.size() > best.faces.size()) best = std::move(c);
        have = true;
        if (ratio <= 1 / 0.85 || iter >= 8) break;
      }
      cells *= std::min(4.0, 0.98 * std::sqrt(ratio));
    }
    if (have) c = std::move(best);  // else (no pass within 40) the last, coarsest one
    std::vector<int> members(static_cast<size_t>(c.clusters), 0);
    cluster_xyz.assign(3 * static_cast<size_t>(c.clusters), 0.0);
    for (int32_t v = 0; v < m.nv(); ++v) {
      const int32_t k = c.cluster_of[static_cast<size_t>(v)];
      if (k < 0) continue;
      members[static_cast<size_t>(k)]++;
      for (int j = 0; j < 3; ++j) cluster_xyz[3 * static_cast<size_t>(k) + static_cast<size_t>(j)] += m.point(v)[j];
    }
    for (size_t k = 0; k < members.size(); ++k)
      for (int j = 0; j < 3; ++j) cluster_xyz[3 * k + static_cast<size_t>(j)] /= std::max(1, members[k]);
    out = std::move(c.faces);
    s.decimated = true;
  } else {
    out = std::move(faces);
  }
  // Group by ref (stable: the mesh's order within a group).
  std::stable_sort(out.begin(), out.end(), [](const Face& a, const Face& b) { return a.ref < b.ref; });
  // Compact the vertices in order of first use.
  const size_t nsrc = s.decimated ? cluster_xyz.size() / 3 : static_cast<size_t>(m.nv());
  std::vector<int32_t> compact(nsrc, -1);
  int32_t next = 0;
  s.tris.reserve(3 * out.size());
  for (size_t i = 0; i < out.size(); ++i) {
    if (i == 0 || out[i].ref != out[i - 1].ref) {
      s.group_ref.push_back(out[i].ref);
      s.group_start.push_back(static_cast<int32_t>(i));
      s.group_count.push_back(0);
    }
    s.group_count.back()++;
    for (int32_t v : out[i].v) {
      int32_t& slot = compact[static_cast<size_t>(v)];
      if (slot < 0) {
        slot = next++;
        const double* p = s.decimated ? &cluster_xyz[3 * static_cast<size_t>(v)] : m.point(v);
        for (int k = 0; k < 3; ++k) s.xyz.push_back(static_cast<float>(p[k] - s.origin[k]));
      }
      s.tris.push_back(slot);
    }
  }
  return s;
}

namespace {

// Appends tet t of m to the set (its vertices through the compact table).
void add_tet(ViewTets& vt, const TetMesh& m, int32_t t, std::unordered_map<int32_t, int32_t>& compact,
             const double origin[3]) {
  const int32_t* v = m.tet(t);
  for (int i = 0; i < 4; ++i) {
    auto [it, fresh] = compact.emplace(v[i], static_cast<int32_t>(vt.xyz.size() / 3));
    if (fresh)
      for (int k = 0; k < 3; ++k) vt.xyz.push_back(static_cast<float>(m.point(v[i])[k] - origin[k]));
    vt.tets.push_back(it->second);
  }
  double lo = 0, hi = 0;
  dihedral_extremes(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3]), lo, hi);
  vt.dihedral_min.push_back(static_cast<float>(lo));
  vt.dihedral_max.push_back(static_cast<float>(hi));
  vt.kind.push_back(m.tet_kind.empty() ? 0 : m.tet_kind[static_cast<size_t>(t)]);
}

}  // namespace

ViewTets view_poor_tets(const TetMesh& m, double threshold, size_t max_tets, const double origin[3],
                        const std::vector<int32_t>* id_map, int threads) {
  ViewTets vt;
  for (int k = 0; k < 3; ++k) vt.origin[k] = origin[k];
  std::vector<double> a(static_cast<size_t>(m.nt()));
  detail::parallel_for_each(m.nt(), threads, [&](int64_t t) {
    a[static_cast<size_t>(t)] = tet_alpha(m, static_cast<int32_t>(t));
  });
  std::vector<int32_t> poor;
  for (int32_t t = 0; t < m.nt(); ++t)
    if (a[static_cast<size_t>(t)] < threshold || std::isnan(a[static_cast<size_t>(t)])) poor.push_back(t);
  vt.below = static_cast<int64_t>(poor.size());
  const size_t keep = std::min(max_tets, poor.size());
  auto worse = [&](int32_t x, int32_t y) {
    const double ax = std::isnan(a[static_cast<size_t>(x)]) ? -2 : a[static_cast<size_t>(x)];
    const double ay = std::isnan(a[static_cast<size_t>(y)]) ? -2 : a[static_cast<size_t>(y)];
    return ax < ay || (ax == ay && x < y);
  };
  std::partial_sort(poor.begin(), poor.begin() + static_cast<std::ptrdiff_t>(keep), poor.end(), worse);
  std::unordered_map<int32_t, int32_t> compact;
  for (size_t i = 0; i < keep; ++i) {
    const int32_t t = poor[i];
    add_tet(vt, m, t, compact, origin);
    vt.ids.push_back(id_map && t < static_cast<int32_t>(id_map->size()) ? (*id_map)[static_cast<size_t>(t)] : t);
    vt.alpha.push_back(static_cast<float>(a[static_cast<size_t>(t)]));
  }
  return vt;
}

ViewTets view_diagnosed_tets(const TetMesh& m, const Diagnosis& d, size_t max_tets, const double origin[3]) {
  ViewTets vt;
  for (int k = 0; k < 3; ++k) vt.origin[k] = origin[k];
  vt.below = static_cast<int64_t>(d.poor.size());
  const size_t keep = std::min(max_tets, d.poor.size());
  std::unordered_map<int32_t, int32_t> compact;
  for (size_t i = 0; i < keep; ++i) {
    const PoorTet& p = d.poor[i];
    add_tet(vt, m, p.tet, compact, origin);
    vt.ids.push_back(p.tet);
    vt.alpha.push_back(static_cast<float>(p.alpha));
    vt.cls.push_back(static_cast<uint8_t>(p.cls));
    vt.best_alpha.push_back(static_cast<float>(p.best_alpha));
    vt.cap_face.push_back(static_cast<int8_t>(p.cls == TetClass::LockedByTriangle ? p.face : -1));
    vt.constrained_faces.push_back(static_cast<uint8_t>(p.constrained_faces));
  }
  return vt;
}

std::string base64(const void* data, size_t n) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* b = static_cast<const unsigned char*>(data);
  std::string o;
  o.reserve((n + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 3 <= n; i += 3) {
    const uint32_t x = static_cast<uint32_t>(b[i]) << 16 | static_cast<uint32_t>(b[i + 1]) << 8 | b[i + 2];
    o += kAlphabet[x >> 18];
    o += kAlphabet[x >> 12 & 63];
    o += kAlphabet[x >> 6 & 63];
    o += kAlphabet[x & 63];
  }
  if (i < n) {
    const uint32_t x = static_cast<uint32_t>(b[i]) << 16 | (i + 1 < n ? static_cast<uint32_t>(b[i + 1]) << 8 : 0u);
    o += kAlphabet[x >> 18];
    o += kAlphabet[x >> 12 & 63];
    o += i + 1 < n ? kAlphabet[x >> 6 & 63] : '=';
    o += '=';
  }
  return o;
}

}  // namespace tetopt
