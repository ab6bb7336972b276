// TetMesh topology, classification and validation (see mesh.hpp).
#include "tetopt/mesh.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <string>

#include "tetopt/predicates.hpp"
#include "tetopt/quality.hpp"
#include "detail/parallel.hpp"
#include "detail/permute_tets.hpp"
#include "detail/sum.hpp"

namespace tetopt {

namespace {
inline void sort3(int32_t& a, int32_t& b, int32_t& c) {
  if (a > b) std::swap(a, b);
  if (b > c) std::swap(b, c);
  if (a > b) std::swap(a, b);
}
}  // namespace

void face_key(const TetMesh& m, int32_t t, int f, int32_t out[3]) {
  const int32_t* v = m.tet(t);
  out[0] = v[kFaceVertex[f][0]];
  out[1] = v[kFaceVertex[f][1]];
  out[2] = v[kFaceVertex[f][2]];
  sort3(out[0], out[1], out[2]);
}

namespace {
// The first index in [0, n) where bad(i) holds (n when none), found over
// fixed blocks in parallel: the same answer for every thread count.
template <class Bad>
int64_t first_index(int64_t n, int threads, const Bad& bad) {
  return detail::parallel_reduce_blocks(
      n, threads, n,
      [&](int64_t b, int64_t e) {
        for (int64_t i = b; i < e; ++i)
          if (bad(i)) return i;
        return n;
      },
      [](int64_t x, int64_t y) { return std::min(x, y); });
}
}  // namespace

Status check_arrays(const TetMesh& m, const std::string& name, int threads) {
  if (m.xyz.size() % 3 != 0 || m.tets.size() % 4 != 0)
    return Status::error(ErrorCode::InvalidMesh, name + ": inconsistent array sizes");
  const int32_t nv = m.nv(), nt = m.nt();
  if (nt == 0) return Status::error(ErrorCode::InvalidMesh, name + ": the mesh has no tetrahedra");
  if (m.tet_ref.size() != static_cast<size_t>(nt))
    return Status::error(ErrorCode::InvalidMesh, name + ": tet_ref size differs from the tet count");
  if (!m.vert_ref.empty() && m.vert_ref.size() != static_cast<size_t>(nv))
    return Status::error(ErrorCode::InvalidMesh, name + ": vert_ref size differs from the vertex count");
  auto first_bad = [&](int64_t n, auto bad) { return first_index(n, threads, bad); };
  const int64_t bad_v = first_bad(nv, [&](int64_t v) {
    const double* p = m.point(static_cast<int32_t>(v));
    return !std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]);
  });
  if (bad_v < nv)
    return Status::error(ErrorCode::InvalidMesh,
                         name + ": vertex " + std::to_string(bad_v + 1) + " has a NaN or infinite coordinate");
  const int64_t bad_t = first_bad(nt, [&](int64_t t) {
    const int32_t* v = m.tet(static_cast<int32_t>(t));
    for (int k = 0; k < 4; ++k)
      if (v[k] < 0 || v[k] >= nv) return true;
    return v[0] == v[1] || v[0] == v[2] || v[0] == v[3] || v[1] == v[2] || v[1] == v[3] || v[2] == v[3];
  });
  for (int32_t t = static_cast<int32_t>(bad_t); t < nt; ++t) {  // the message for the first bad tet
    const int32_t* v = m.tet(t);
    for (int k = 0; k < 4; ++k)
      if (v[k] < 0 || v[k] >= nv)
        return Status::error(ErrorCode::InvalidMesh, name + ": tetrahedron " + std::to_string(t + 1) +
                                                         " names vertex " + std::to_string(v[k] + 1) +
                                                         ", outside 1.." + std::to_string(nv));
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j)
        if (v[i] == v[j])
          return Status::error(ErrorCode::InvalidMesh, name + ": tetrahedron " + std::to_string(t + 1) +
                                                           " repeats vertex " + std::to_string(v[i] + 1));
  }
  auto check_list = [&](const std::vector<int32_t>& a, int per, const char* what) -> Status {
    if (a.size() % per) return Status::error(ErrorCode::InvalidMesh, name + ": bad " + what + " array");
    for (size_t i = 0; i < a.size(); ++i)
      if (a[i] < 0 || a[i] >= nv)
        return Status::error(ErrorCode::InvalidMesh, name + ": " + what + " " + std::to_string(i / per + 1) +
                                                         " names vertex " + std::to_string(a[i] + 1) +
                                                         ", outside 1.." + std::to_string(nv));
    return Status::success();
  };
  if (Status s = check_list(m.tris, 3, "triangle"); !s) return s;
  if (Status s = check_list(m.edges, 2, "edge"); !s) return s;
  if (Status s = check_list(m.required_vertices, 1, "required vertex"); !s) return s;
  if (Status s = check_list(m.corners, 1, "corner"); !s) return s;
  if (!m.tet_entity.empty() && m.tet_entity.size() != static_cast<size_t>(nt))
    return Status::error(ErrorCode::InvalidMesh, name + ": tet_entity size differs from the tet count");
  if (!m.tri_entity.empty() && m.tri_entity.size() != m.tris.size() / 3)
    return Status::error(ErrorCode::InvalidMesh, name + ": tri_entity size differs from the triangle count");
  for (const auto& f : m.point_fields)
    if (f.components < 1 || f.values.size() != static_cast<size_t>(nv) * static_cast<size_t>(f.components))
      return Status::error(ErrorCode::InvalidMesh, name + ": point field '" + f.name + "' has the wrong size");
  if (m.tri_ref.size() != m.tris.size() / 3 || m.edge_ref.size() != m.edges.size() / 2)
    return Status::error(ErrorCode::InvalidMesh, name + ": ref arrays differ from entity counts");
  for (int32_t i : m.required_tris)
    if (i < 0 || i >= m.ntri())
      return Status::error(ErrorCode::InvalidMesh, name + ": required triangle index out of range");
  for (const auto* lst : {&m.required_edges, &m.ridges})
    for (int32_t i : *lst)
      if (i < 0 || static_cast<size_t>(i) >= m.edges.size() / 2)
        return Status::error(ErrorCode::InvalidMesh, name + ": required edge or ridge index out of range");
  return Status::success();
}

OrientationReport normalize_orientation(TetMesh& m, int threads) {
  OrientationReport r;
  const int32_t nt = m.nt();
  std::vector<int8_t> sign(nt);
  detail::parallel_for_each(nt, threads, [&](int64_t i) {
    const int32_t* v = m.tet(static_cast<int32_t>(i));
    sign[i] = static_cast<int8_t>(orient3d(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3])));
  });
  for (int32_t t = 0; t < nt; ++t) {
    if (sign[t] > 0) r.positive++;
    else if (sign[t] < 0) r.negative++;
    else r.flat++;
  }
  if (r.negative > r.positive) {
    detail::parallel_for_each(nt, threads, [&](int64_t t) {
      std::swap(m.tets[4 * static_cast<size_t>(t) + kFlipA], m.tets[4 * static_cast<size_t>(t) + kFlipB]);
      sign[t] = static_cast<int8_t>(-sign[t]);
    });
    std::swap(r.positive, r.negative);
    m.flipped_on_read = !m.flipped_on_read;
    r.flipped = true;
  }
  for (int32_t t = 0; t < nt; ++t) {
    if (sign[t] < 0) r.inverted.push_back(t);
    else if (sign[t] == 0) r.flat_tets.push_back(t);
  }
  return r;
}

Status check_measurable(const TetMesh& m, const std::string& name, int threads) {
  // Fourth and fifth powers of edge lengths (areas squared times lengths)
  // overflow a double from about 1e76 on: every tet then measured alpha 0,
  // "flat", in silence.  1e60 leaves room.
  constexpr double kMaxCoord = 1e60;
  const int64_t nv = m.nv();
  const int64_t bad = first_index(nv, threads, [&](int64_t v) {
    const double* p = m.point(static_cast<int32_t>(v));
    return !(std::fabs(p[0]) <= kMaxCoord) || !(std::fabs(p[1]) <= kMaxCoord) || !(std::fabs(p[2]) <= kMaxCoord);
  });
  if (bad != nv)
    return Status::error(ErrorCode::InvalidMesh, (name.empty() ? "" : name + ": ") + "vertex " + std::to_string(bad + 1) +
                                                     " has a coordinate beyond 1e60 in magnitude, where the quality "
                                                     "measures overflow (rescale the mesh)");
  // The same powers underflow for tiny tets: a mesh scaled by 1e-90 measured
  // every tet flat (alpha 0) in silence, and by 1e-80 alpha was already off
  // in the fifth digit.  A tet whose longest edge is below 1e-60 (but not 0:
  // four coincident vertices are simply flat) cannot exist beside
  // coordinates of ordinary size (doubles keep 16 digits), so it means a
  // mesh in the wrong units.
  // (Measured by the largest coordinate difference, which does not
  // underflow as a squared length would.)  The tets are looked at only when
  // no coordinate reaches 1e-40: beside such a coordinate a tet that small
  // is flat relative to the mesh (the pass over the tets cost 6 ms of the
  // demo impeller's load at 1 thread; the largest coordinate costs 0.3 ms).
  constexpr double kMinEdge = 1e-60, kOrdinary = 1e-40;
  const double largest = detail::parallel_reduce_blocks(
      nv, threads, 0.0,
      [&](int64_t b, int64_t e) {
        double x = 0;
        for (int64_t v = b; v < e; ++v)
          for (int k = 0; k < 3; ++k) x = std::max(x, std::fabs(m.point(static_cast<int32_t>(v))[k]));
        return x;
      },
      [](double x, double y) { return std::max(x, y); });
  if (largest >= kOrdinary) return Status::success();
  const int64_t nt = m.nt();
  const int64_t tiny = first_index(nt, threads, [&](int64_t t) {
    const int32_t* v = m.tet(static_cast<int32_t>(t));
    double len = 0;
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) {
        const double* p = m.point(v[a]);
        const double* q = m.point(v[b]);
        for (int k = 0; k < 3; ++k) len = std::max(len, std::fabs(p[k] - q[k]));
      }
    return len > 0 && len < kMinEdge;
  });
  if (tiny == nt) return Status::success();
  return Status::error(ErrorCode::InvalidMesh, (name.empty() ? "" : name + ": ") + "tet " + std::to_string(tiny + 1) +
                                                   " spans less than 1e-60 along every axis, where the quality measures "
                                                   "underflow (rescale the mesh)");
}

Status compact_vertices(TetMesh& m, const std::vector<int32_t>& drop, std::vector<int32_t>* map) {
  const int32_t nv = m.nv();
  std::vector<int32_t> to(static_cast<size_t>(nv), 0);
  for (int32_t v : drop) {
    if (v < 0 || v >= nv) return Status::error(ErrorCode::Invariant, "compact_vertices: vertex id out of range");
    to[v] = -1;
  }
  auto referenced = [&](const std::vector<int32_t>& ids) {
    for (int32_t v : ids)
      if (v >= 0 && v < nv && to[v] < 0) return true;
    return false;
  };
  if (referenced(m.tets) || referenced(m.tris) || referenced(m.edges) || referenced(m.required_vertices) ||
      referenced(m.corners))
    return Status::error(ErrorCode::Invariant, "compact_vertices: a dropped vertex is still referenced");
  int32_t n = 0;
  for (int32_t v = 0; v < nv; ++v) to[v] = to[v] < 0 ? -1 : n++;
  if (n == nv) {
    if (map) *map = std::move(to);
    return Status::success();
  }
  const bool has_vref = m.vert_ref.size() == static_cast<size_t>(nv);
  const bool has_flags = m.vert_constrained.size() == static_cast<size_t>(nv);
  for (int32_t v = 0; v < nv; ++v) {
    const int32_t w = to[v];
    if (w < 0 || w == v) continue;
    std::copy(m.point(v), m.point(v) + 3, m.point(w));
    if (has_vref) m.vert_ref[w] = m.vert_ref[v];
    if (has_flags) m.vert_constrained[w] = m.vert_constrained[v];
  }
  m.xyz.resize(3 * static_cast<size_t>(n));
  if (has_vref) m.vert_ref.resize(n);
  if (has_flags) m.vert_constrained.resize(n);
  for (auto& pf : m.point_fields) {
    const size_t c = static_cast<size_t>(pf.components);
    if (pf.values.size() != c * static_cast<size_t>(nv)) continue;
    for (int32_t v = 0; v < nv; ++v)
      if (to[v] >= 0 && to[v] != v)
        std::copy(&pf.values[c * v], &pf.values[c * v] + c, &pf.values[c * static_cast<size_t>(to[v])]);
    pf.values.resize(c * static_cast<size_t>(n));
  }
  // tri_keys stay sorted: the renumbering keeps the order of the kept ids.
  for (auto* ids : {&m.tets, &m.tris, &m.edges, &m.required_vertices, &m.corners, &m.tri_keys})
    for (int32_t& v : *ids)
      if (v >= 0 && v < nv) v = to[v];
  if (m.vt_offsets.size() == static_cast<size_t>(nv) + 1) build_vertex_tets(m);
  m.topology_epoch++;
  if (map) *map = std::move(to);
  return Status::success();
}

namespace {
// The vertex->tet CSR of `tets` over nv vertices, tets in increasing order in
// every star.  In parallel the tets are cut into P consecutive parts; part p
// counts its entries per vertex, and vertex v's entries from part p start
// after those of parts 0..p-1, so each part scatters its own tets in order and
// the result is the serial one for every thread count (a former count and
// scatter with atomic increments, then sorting every star, was 5-8x slower on
// the impeller at 2 threads; owning vertex ranges instead of tet ranges paid
// a mispredicted branch per entry and was 2x slower than serial).
void star_csr(const std::vector<int32_t>& tets, int32_t nv, std::vector<int32_t>& off, std::vector<int32_t>& vt,
              int threads) {
  off.assign(static_cast<size_t>(nv) + 1, 0);
  vt.resize(tets.size());
  const size_t n = tets.size();
  // P count arrays of nv entries: at most as many as the tets' entries/4.
  // Four parts per thread: with one per thread, the thread that started
  // late (or took more page faults) finished alone, about 30 ms a run at 2
  // threads on the demo impeller.  The result does not depend on P.
  const int64_t nthreads = detail::resolve_threads(threads);
  int64_t parts = n >= (size_t{1} << 16) && nthreads > 1 ? 4 * nthreads : 1;
  parts = std::min<int64_t>(parts, std::max<int64_t>(1, static_cast<int64_t>(n / 4) / std::max(nv, 1)));
  if (parts <= 1) {
    for (int32_t v : tets) off[v + 1]++;
    for (int32_t v = 0; v < nv; ++v) off[v + 1] += off[v];
    std::vector<int32_t> fill(off.begin(), off.end() - 1);
    for (size_t i = 0; i < n; ++i) vt[fill[tets[i]]++] = static_cast<int32_t>(i / 4);
    return;
  }
  // Part boundaries on whole tets.
  auto bound = [&](int64_t p) { return static_cast<size_t>(p * static_cast<int64_t>(n / 4) / parts) * 4; };
  std::vector<std::vector<int32_t>> cnt(static_cast<size_t>(parts));
  detail::parallel_items(parts, threads, [&](int64_t p) {
    std::vector<int32_t>& c = cnt[static_cast<size_t>(p)];
    c.assign(static_cast<size_t>(nv), 0);
    for (size_t i = bound(p), e = bound(p + 1); i < e; ++i) c[tets[i]]++;
  });
  // off from the totals; cnt[p][v] becomes the first slot of part p in v's star.
  for (int32_t v = 0; v < nv; ++v) {
    int32_t at = off[v];
    for (auto& c : cnt) {
      const int32_t k = c[v];
      c[v] = at;
      at += k;
    }
    off[v + 1] = at;
  }
  detail::parallel_items(parts, threads, [&](int64_t p) {
    int32_t* fill = cnt[static_cast<size_t>(p)].data();
    for (size_t i = bound(p), e = bound(p + 1); i < e; ++i) vt[fill[tets[i]]++] = static_cast<int32_t>(i / 4);
  });
}
}  // namespace

void build_vertex_tets(TetMesh& m, int threads) { star_csr(m.tets, m.nv(), m.vt_offsets, m.vt_tets, threads); }

void ensure_vertex_tets(TetMesh& m, int threads) {
  if (m.vt_offsets.size() != static_cast<size_t>(m.nv()) + 1) build_vertex_tets(m, threads);
}

namespace {
// An error found in a parallel block, with the position it was found at so
// that the first one in serial order is reported whatever the thread count.
struct FirstError {
  int64_t at = std::numeric_limits<int64_t>::max();
  Status status;
};
FirstError earlier(const FirstError& a, const FirstError& b) { return b.at < a.at ? b : a; }
// Two tets sharing two faces have the same four vertices: a duplicate.
Status check_duplicates(const TetMesh& m, int threads);
// Per face of the tets from first_tet on (4 entries per tet, in order), 1 if
// it is a listed triangle: each triangle is looked up in the smallest star
// of its three vertices (stars must be built).  touched (optional, per vertex): skip
// triangles with a vertex outside it.  Empty when the mesh lists none.
std::vector<uint8_t> listed_faces(const TetMesh& m, int32_t first_tet, const std::vector<uint8_t>* touched,
                                  int threads) {
  std::vector<uint8_t> listed;
  if (m.tris.empty()) return listed;
  listed.assign(4 * static_cast<size_t>(m.nt() - first_tet), 0);
  // Triangles in parallel blocks, each listing the faces it found; marked
  // after (a triangle listed twice finds the same faces).
  for (const std::vector<size_t>& part : detail::parallel_map_blocks(m.ntri(), threads, [&](int64_t b0, int64_t e0) {
         std::vector<size_t> found;
         for (auto i = static_cast<int32_t>(b0); i < e0; ++i) {
           const int32_t a = m.tris[3 * i], b = m.tris[3 * i + 1], c = m.tris[3 * i + 2];
           if (touched && (!(*touched)[a] || !(*touched)[b] || !(*touched)[c])) continue;
           // The tets holding the triangle are in the star of each of its
           // vertices: scan the smallest.
           int32_t s = a;
           if (m.star_end(b) - m.star_begin(b) < m.star_end(s) - m.star_begin(s)) s = b;
           if (m.star_end(c) - m.star_begin(c) < m.star_end(s) - m.star_begin(s)) s = c;
           for (const int32_t* it = m.star_begin(s); it != m.star_end(s); ++it) {
             if (*it < first_tet) continue;
             const int32_t* v = m.tet(*it);
             int has = 0, other = -1;
             for (int k = 0; k < 4; ++k) {
               if (v[k] == a || v[k] == b || v[k] == c) ++has;
               else other = k;
             }
             if (has == 3 && other >= 0) found.push_back(4 * static_cast<size_t>(*it - first_tet) + other);
           }
         }
         return found;
       }))
    for (const size_t f : part) listed[f] = 1;
  return listed;
}
// face_mask of tet t: bit f set when face f is on the boundary, between two
// region refs or two Gmsh entities (entity boundaries are geometry the user
// gave, even inside one region), or a listed triangle (listed4: the tet's
// four flags from listed_faces, or null).
uint8_t constrained_faces(const TetMesh& m, int32_t t, bool has_entity, const uint8_t* listed4) {
  uint8_t mask = 0;
  for (int f = 0; f < 4; ++f) {
    const int32_t n = m.adj[4 * static_cast<size_t>(t) + f];
    bool c = n < 0 || m.tet_ref[n / 4] != m.tet_ref[t] || (has_entity && m.tet_entity[n / 4] != m.tet_entity[t]);
    if (!c && listed4) c = listed4[f] != 0;
    if (c) mask |= static_cast<uint8_t>(1u << f);
  }
  return mask;
}
}  // namespace

Status build_adjacency_sorted(TetMesh& m, int threads) {
  // Faces are bucketed by their smallest vertex (counting sort), then each
  // small bucket is sorted by the two other vertices; equal neighbours pair
  // up.  The buckets are independent (every face is in one), so they are
  // sorted and paired in parallel blocks of vertices.
  const int32_t nv = m.nv(), nt = m.nt();
  const size_t nf = 4 * static_cast<size_t>(nt);
  std::vector<int32_t> off(static_cast<size_t>(nv) + 1, 0);
  for (int32_t t = 0; t < nt; ++t)
    for (int f = 0; f < 4; ++f) {
      int32_t k[3];
      face_key(m, t, f, k);
      off[k[0] + 1]++;
    }
  for (int32_t v = 0; v < nv; ++v) off[v + 1] += off[v];
  struct Entry {
    int32_t b, c;  // second and third vertex of the sorted face
    int32_t face;  // packed 4t+f
  };
  // Default-initialised (not zero-filled): every slot is written below.
  std::unique_ptr<Entry[]> ent(new Entry[nf]);
  {
    std::vector<int32_t> fill(off.begin(), off.end() - 1);
    for (int32_t t = 0; t < nt; ++t)
      for (int f = 0; f < 4; ++f) {
        int32_t k[3];
        face_key(m, t, f, k);
        ent[fill[k[0]]++] = {k[1], k[2], 4 * t + f};
      }
  }
  m.adj.assign(nf, -1);
  auto bucket = [&](int32_t v) -> Status {
    Entry* b = ent.get() + off[v];
    Entry* e = ent.get() + off[v + 1];
    std::sort(b, e, [](const Entry& x, const Entry& y) {
      return x.b != y.b ? x.b < y.b : (x.c != y.c ? x.c < y.c : x.face < y.face);
    });
    for (Entry* p = b; p < e;) {
      Entry* q = p + 1;
      while (q < e && q->b == p->b && q->c == p->c) ++q;
      const long cnt = q - p;
      if (cnt > 2) {
        for (Entry* r = p; r < q; ++r)
          for (Entry* w = r + 1; w < q; ++w) {
            int32_t ta[4], tb[4];
            std::copy(m.tet(r->face / 4), m.tet(r->face / 4) + 4, ta);
            std::copy(m.tet(w->face / 4), m.tet(w->face / 4) + 4, tb);
            std::sort(ta, ta + 4);
            std::sort(tb, tb + 4);
            if (std::equal(ta, ta + 4, tb))
              return Status::error(ErrorCode::InvalidMesh,
                                   "tetrahedra " + std::to_string(r->face / 4 + 1) + " and " +
                                       std::to_string(w->face / 4 + 1) +
                                       " have the same four vertices (duplicate tetrahedron)");
          }
        std::string ids;
        for (Entry* r = p; r < q; ++r) ids += (r == p ? "" : ", ") + std::to_string(r->face / 4 + 1);
        return Status::error(ErrorCode::InvalidMesh,
                             "face (" + std::to_string(v + 1) + ", " + std::to_string(p->b + 1) + ", " +
                                 std::to_string(p->c + 1) + ") is shared by " +
                                 std::to_string(cnt) + " tetrahedra (" + ids + "): the mesh is not manifold");
      }
      if (cnt == 2) {
        m.adj[p[0].face] = p[1].face;
        m.adj[p[1].face] = p[0].face;
      }
      p = q;
    }
    return Status::success();
  };
  FirstError err = detail::parallel_reduce_blocks(
      nv, threads, FirstError{},
      [&](int64_t b, int64_t e) {
        for (int64_t v = b; v < e; ++v)
          if (Status s = bucket(static_cast<int32_t>(v)); !s) return FirstError{v, s};
        return FirstError{};
      },
      earlier);
  if (!err.status) return err.status;
  return check_duplicates(m, threads);
}

namespace {
// Face adjacency from the vertex stars (off/vt as in TetMesh::vt_offsets /
// vt_tets): the faces whose smallest vertex is v are found among the tets of
// v's star, sorted by their two other vertices, and equal neighbours pair
// up -- the buckets of build_adjacency_sorted, gathered per vertex instead of
// by a global counting sort, so every vertex is independent and the loop is
// parallel (its result does not depend on the thread count).  Returns false
// on anything a valid mesh cannot have (a face in three or more tets, or a
// one-sided link); the caller then runs build_adjacency_sorted, which finds
// the same links and reports the first defect in its own order.
// only: when not null, the buckets of these vertices alone are rebuilt (the
// other entries of adj are left as they are); the symmetry check covers
// every link, the kept ones too.
bool adjacency_from_stars(TetMesh& m, const std::vector<int32_t>& off, const std::vector<int32_t>& vt, int threads,
                          const std::vector<int32_t>* only = nullptr) {
  const int32_t nt = m.nt();
  const int32_t nv = only ? static_cast<int32_t>(only->size()) : static_cast<int32_t>(off.size()) - 1;
  m.adj.resize(4 * static_cast<size_t>(nt));
  std::atomic<bool> ok{true};
  // The faces whose smallest vertex is v, keyed by their other two vertices
  // (packed in 64 bits); equal keys must end up next to each other (their
  // order does not matter: two faces pair, more is an error).  Stars are
  // small: insertion sort, std::sort for a large one.
  struct Entry {
    uint64_t key;
    int32_t face;
  };
  // Vertices are independent (each writes the links of its own faces):
  // ranges of 512 stars keep both threads busy to the end.
  detail::parallel_ranges(nv, 512, threads, [&](int64_t vb, int64_t ve) {
    std::vector<Entry> ent;
    for (int64_t vi = vb; vi < ve; ++vi) {
      const auto v = only ? (*only)[static_cast<size_t>(vi)] : static_cast<int32_t>(vi);
      ent.clear();
      for (int32_t i = off[v]; i < off[v + 1]; ++i) {
        const int32_t t = vt[i];
        const int32_t* tv = m.tet(t);
        for (int f = 0; f < 4; ++f) {
          int32_t k0 = tv[kFaceVertex[f][0]], k1 = tv[kFaceVertex[f][1]], k2 = tv[kFaceVertex[f][2]];
          sort3(k0, k1, k2);
          if (k0 == v)
            ent.push_back({static_cast<uint64_t>(static_cast<uint32_t>(k1)) << 32 | static_cast<uint32_t>(k2), 4 * t + f});
        }
      }
      if (ent.size() <= 128) {
        for (size_t j = 1; j < ent.size(); ++j) {
          const Entry x = ent[j];
          size_t k = j;
          for (; k > 0 && ent[k - 1].key > x.key; --k) ent[k] = ent[k - 1];
          ent[k] = x;
        }
      } else {
        std::sort(ent.begin(), ent.end(), [](const Entry& x, const Entry& y) {
          return x.key != y.key ? x.key < y.key : x.face < y.face;
        });
      }
      for (size_t j = 0; j < ent.size();) {
        size_t k = j + 1;
        while (k < ent.size() && ent[k].key == ent[j].key) ++k;
        if (k - j > 2) { ok.store(false, std::memory_order_relaxed); return; }
        if (k - j == 2) {
          m.adj[ent[j].face] = ent[j + 1].face;
          m.adj[ent[j + 1].face] = ent[j].face;
        } else {
          m.adj[ent[j].face] = -1;
        }
        j = k;
      }
    }
  });
  if (!ok.load()) return false;
  // Both sides must name each other (a tet with a repeated vertex breaks it).
  const bool sym = detail::parallel_reduce_blocks(
      static_cast<int64_t>(m.adj.size()), threads, true,
      [&](int64_t b, int64_t e) {
        for (int64_t x = b; x < e; ++x) {
          const int32_t y = m.adj[x];
          if (y >= 0 && m.adj[y] != x) return false;
        }
        return true;
      },
      [](bool a, bool c) { return a && c; });
  return sym;
}

}  // namespace

Status build_adjacency(TetMesh& m, int threads) {
  std::vector<int32_t> off, vt;  // stars of its own: m's may be stale or absent
  star_csr(m.tets, m.nv(), off, vt, threads);
  if (!adjacency_from_stars(m, off, vt, threads)) return build_adjacency_sorted(m, threads);
  return check_duplicates(m, threads);
}
namespace {
Status check_duplicates(const TetMesh& m, int threads) {
  // Two tets sharing two faces have the same four vertices: a duplicate.
  const int32_t nt = m.nt();
  FirstError err = detail::parallel_reduce_blocks(
      nt, threads, FirstError{},
      [&](int64_t b, int64_t e) {
        for (int64_t t = b; t < e; ++t)
          for (int f = 0; f < 4; ++f)
            for (int g = f + 1; g < 4; ++g) {
              const int32_t x = m.adj[4 * t + f], y = m.adj[4 * t + g];
              if (x >= 0 && y >= 0 && x / 4 == y / 4)
                return FirstError{t, Status::error(ErrorCode::InvalidMesh,
                                                   "tetrahedra " + std::to_string(t + 1) + " and " +
                                                       std::to_string(x / 4 + 1) +
                                                       " have the same four vertices (duplicate tetrahedron)")};
            }
        return FirstError{};
      },
      earlier);
  return err.status;
}
}  // namespace

void build_tri_keys(const std::vector<int32_t>& tris, std::vector<int32_t>& keys) {
  const size_t n = tris.size() / 3;
  std::vector<std::array<int32_t, 3>> k(n);
  for (size_t i = 0; i < n; ++i) {
    k[i] = {tris[3 * i], tris[3 * i + 1], tris[3 * i + 2]};
    std::sort(k[i].begin(), k[i].end());
  }
  std::sort(k.begin(), k.end());
  keys.resize(3 * n);
  for (size_t i = 0; i < n; ++i) std::copy(k[i].begin(), k[i].end(), &keys[3 * i]);
}

void classify(TetMesh& m, int threads) {
  const int32_t nv = m.nv(), nt = m.nt();
  build_tri_keys(m.tris, m.tri_keys);
  m.face_mask.assign(nt, 0);
  m.vert_constrained.assign(nv, 0);
  m.tet_kind.assign(nt, 0);
  // Listed triangles are constrained faces: mark the face of every tet
  // holding one, found in the smallest star of its vertices (a binary search per
  // interior face was 60% of this function on flange_large).
  const std::vector<uint8_t> listed = listed_faces(m, 0, nullptr, threads);
  const bool has_entity = m.tet_entity.size() == static_cast<size_t>(nt);
  // Face masks in parallel (each tet writes its own), then the vertices of
  // the constrained faces serially (few, and shared between tets).
  detail::parallel_for_each(nt, threads, [&](int64_t ti) {
    const auto t = static_cast<int32_t>(ti);
    m.face_mask[t] = constrained_faces(m, t, has_entity, listed.empty() ? nullptr : &listed[4 * static_cast<size_t>(t)]);
  });
  for (int32_t t = 0; t < nt; ++t) {
    const uint8_t mask = m.face_mask[t];
    if (!mask) continue;
    const int32_t* v = m.tet(t);
    for (int f = 0; f < 4; ++f)
      if (mask & (1u << f))
        for (int i = 0; i < 3; ++i) m.vert_constrained[v[kFaceVertex[f][i]]] = 1;
  }
  for (int32_t v : m.required_vertices) m.vert_constrained[v] = 1;
  for (int32_t v : m.corners) m.vert_constrained[v] = 1;
  for (int32_t v : m.edges) m.vert_constrained[v] = 1;
  // Every listed triangle's vertices, also of a triangle that is no tet's
  // face (a file may list a surface that does not conform to the tets): the
  // triangle is written back, so its corners must not move; a flip never
  // makes it a face (TopoEditor refuses a new face that is listed).  Listed
  // triangles on tet faces were marked above.
  for (int32_t v : m.tris) m.vert_constrained[v] = 1;
  detail::parallel_for_each(nt, threads, [&](int64_t t) {
    const int32_t* v = m.tet(static_cast<int32_t>(t));
    m.tet_kind[t] = static_cast<uint8_t>(m.vert_constrained[v[0]] + m.vert_constrained[v[1]] +
                                         m.vert_constrained[v[2]] + m.vert_constrained[v[3]]);
  });
}

bool topology_current(const TetMesh& m) {
  const size_t nt = m.tets.size() / 4;
  return m.adj.size() == m.tets.size() && m.face_mask.size() == nt && m.tet_kind.size() == nt &&
         m.vert_constrained.size() == static_cast<size_t>(m.nv());
}

Status build_topology(TetMesh& m, int threads) {
  build_vertex_tets(m, threads);
  if (!adjacency_from_stars(m, m.vt_offsets, m.vt_tets, threads)) {
    if (Status s = build_adjacency_sorted(m, threads); !s) return s;
  } else if (Status s = check_duplicates(m, threads); !s) {
    return s;
  }
  classify(m, threads);
  m.topology_epoch++;
  return Status::success();
}

namespace {
// The bits of a 21-bit integer spread three apart (Morton interleaving).
uint64_t spread3(uint64_t x) {
  x &= 0x1fffff;
  x = (x | x << 32) & 0x1f00000000ffffULL;
  x = (x | x << 16) & 0x1f0000ff0000ffULL;
  x = (x | x << 8) & 0x100f00f00f00f00fULL;
  x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
  x = (x | x << 2) & 0x1249249249249249ULL;
  return x;
}
}  // namespace

void sort_tets_spatially(TetMesh& m, int threads, std::vector<int32_t>* order) {
  const int32_t nt = m.nt();
  if (order) {
    order->resize(static_cast<size_t>(nt));
    for (int32_t t = 0; t < nt; ++t) (*order)[static_cast<size_t>(t)] = t;
  }
  if (nt < 2) return;
  double lo[3] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                  std::numeric_limits<double>::infinity()};
  double hi[3] = {-lo[0], -lo[1], -lo[2]};
  for (int32_t v = 0; v < m.nv(); ++v)
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], m.point(v)[d]);
      hi[d] = std::max(hi[d], m.point(v)[d]);
    }
  // Key: the Morton code of the centroid on a 2^21 grid per axis, then the
  // old index (a total order: the same permutation for every thread count).
  std::vector<std::pair<uint64_t, int32_t>> key(static_cast<size_t>(nt));
  detail::parallel_for_each(nt, threads, [&](int64_t ti) {
    const auto t = static_cast<int32_t>(ti);
    const int32_t* v = m.tet(t);
    uint64_t code = 0;
    for (int d = 0; d < 3; ++d) {
      const double c = (m.point(v[0])[d] + m.point(v[1])[d] + m.point(v[2])[d] + m.point(v[3])[d]) / 4;
      const double span = hi[d] - lo[d];
      double q = span > 0 ? (c - lo[d]) / span * 2097151.0 : 0.0;
      q = std::min(std::max(q, 0.0), 2097151.0);
      code |= spread3(static_cast<uint64_t>(q)) << d;
    }
    key[static_cast<size_t>(t)] = {code, t};
  });
  std::sort(key.begin(), key.end());
  if (order)
    for (int32_t i = 0; i < nt; ++i) (*order)[static_cast<size_t>(i)] = key[static_cast<size_t>(i)].second;
  detail::permute_tets(m, [&](int32_t i) { return key[static_cast<size_t>(i)].second; });
}

double tet_order_spread(const TetMesh& m, int threads) {
  const int32_t nt = m.nt();
  if (nt < 2) return 0;
  struct Sums {
    double step = 0, edge = 0;
  };
  auto centroid = [&](int32_t t, int d) {
    const int32_t* v = m.tet(t);
    return (m.point(v[0])[d] + m.point(v[1])[d] + m.point(v[2])[d] + m.point(v[3])[d]) / 4;
  };
  // Per-block sums joined in block order: the same value for every thread count.
  const Sums s = detail::parallel_reduce_blocks(
      nt - 1, threads, Sums{},
      [&](int64_t b, int64_t e) {
        Sums r;
        for (auto t = static_cast<int32_t>(b); t < e; ++t) {
          double st = 0, ed = 0;
          for (int d = 0; d < 3; ++d) {
            const double c = centroid(t + 1, d) - centroid(t, d);
            const double x = m.point(m.tet(t)[1])[d] - m.point(m.tet(t)[0])[d];
            st += c * c;
            ed += x * x;
          }
          r.step += std::sqrt(st);
          r.edge += std::sqrt(ed);
        }
        return r;
      },
      [](Sums a, const Sums& b) {
        a.step += b.step;
        a.edge += b.edge;
        return a;
      });
  return s.edge > 0 ? s.step / s.edge : 0;
}

Status refresh_topology(TetMesh& m, int32_t first_new, int threads) {
  const int32_t nv = m.nv(), nt = m.nt();
  if (first_new < 0 || first_new > nt || m.adj.size() < 4 * static_cast<size_t>(first_new) ||
      m.face_mask.size() < static_cast<size_t>(first_new) || m.tet_kind.size() < static_cast<size_t>(first_new) ||
      m.vert_constrained.size() > static_cast<size_t>(nv))
    return Status::error(ErrorCode::Invariant, "refresh_topology: the kept tets' topology is not built");
  if (first_new == 0) return build_topology(m, threads);
  m.adj.resize(4 * static_cast<size_t>(nt));
  std::fill(m.adj.begin() + 4 * static_cast<ptrdiff_t>(first_new), m.adj.end(), -1);
  build_vertex_tets(m, threads);
  // Every face that changed has all three vertices on new tets: faces of the
  // new tets, and faces of kept tets that the replaced tets shared (they are
  // faces of new tets again when the replacement conforms).  Their buckets
  // are rebuilt; the kept tets' other links stay.
  std::vector<uint8_t> touched(static_cast<size_t>(nv), 0);
  for (size_t i = 4 * static_cast<size_t>(first_new); i < m.tets.size(); ++i) touched[m.tets[i]] = 1;
  std::vector<int32_t> only;
  for (int32_t v = 0; v < nv; ++v)
    if (touched[v]) only.push_back(v);
  if (!adjacency_from_stars(m, m.vt_offsets, m.vt_tets, threads, &only)) return build_topology(m, threads);
  if (Status s = check_duplicates(m, threads); !s) return s;
  // Classification: the kept tets keep theirs (their faces and the refs
  // across them are unchanged); vertices added with the new tets are free.
  m.vert_constrained.resize(static_cast<size_t>(nv), 0);
  m.face_mask.resize(static_cast<size_t>(nt));
  m.tet_kind.resize(static_cast<size_t>(nt));
  const size_t nnew = static_cast<size_t>(nt - first_new);
  const std::vector<uint8_t> listed = listed_faces(m, first_new, &touched, threads);
  const bool has_entity = m.tet_entity.size() == static_cast<size_t>(nt);
  detail::parallel_for_each(static_cast<int64_t>(nnew), threads, [&](int64_t i) {
    const auto t = static_cast<int32_t>(first_new + i);
    m.face_mask[t] = constrained_faces(m, t, has_entity, listed.empty() ? nullptr : &listed[4 * static_cast<size_t>(i)]);
    const int32_t* v = m.tet(t);
    m.tet_kind[t] = static_cast<uint8_t>(m.vert_constrained[v[0]] + m.vert_constrained[v[1]] +
                                         m.vert_constrained[v[2]] + m.vert_constrained[v[3]]);
  });
  m.topology_epoch++;
  return Status::success();
}

Status validate(const TetMesh& m, ValidateLevel level) {
  if (Status s = check_arrays(m); !s) return s;
  const int32_t nt = m.nt();
  if (m.adj.size() != m.tets.size() || m.face_mask.size() != static_cast<size_t>(nt) ||
      m.tet_kind.size() != static_cast<size_t>(nt) || m.vert_constrained.size() != static_cast<size_t>(m.nv()))
    return Status::error(ErrorCode::Invariant, "topology arrays are not built or stale");
  if (level == ValidateLevel::Cheap) return Status::success();
  for (int32_t t = 0; t < nt; ++t) {
    const int32_t* v = m.tet(t);
    if (orient3d(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3])) != Sign::Positive)
      return Status::error(ErrorCode::Invariant,
                           "tetrahedron " + std::to_string(t + 1) + " is inverted or flat");
    for (int f = 0; f < 4; ++f) {
      const int32_t n = m.adj[4 * t + f];
      if (n < 0) continue;
      if (n >= static_cast<int32_t>(m.adj.size()) || m.adj[n] != 4 * t + f)
        return Status::error(ErrorCode::Invariant,
                             "adjacency of tetrahedron " + std::to_string(t + 1) + " is not symmetric");
      int32_t a[3], b[3];
      face_key(m, t, f, a);
      face_key(m, n / 4, n % 4, b);
      if (a[0] != b[0] || a[1] != b[1] || a[2] != b[2])
        return Status::error(ErrorCode::Invariant,
                             "tetrahedra " + std::to_string(t + 1) + " and " + std::to_string(n / 4 + 1) +
                                 " are marked adjacent but do not share the face");
    }
  }
  // Rebuild adjacency from scratch on a copy and compare: catches faces
  // shared by three tets and neighbours that were never linked.
  TetMesh copy;
  copy.xyz = m.xyz;
  copy.tets = m.tets;
  copy.tet_ref = m.tet_ref;
  if (Status s = build_adjacency_sorted(copy); !s) return Status::error(ErrorCode::Invariant, s.message);
  if (copy.adj != m.adj) return Status::error(ErrorCode::Invariant, "stored adjacency differs from a rebuild");
  return Status::success();
}

double tet_volume(const TetMesh& m, int32_t t) {
  const int32_t* v = m.tet(t);
  return tet_signed_volume(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3]));
}

std::vector<std::pair<int32_t, double>> region_volumes(const TetMesh& m, int threads) {
  using Acc = std::map<int32_t, detail::Sum>;  // per ref
  Acc acc;
  for (const Acc& part : detail::parallel_map_blocks(m.nt(), threads, [&](int64_t b, int64_t e) {
         Acc a;
         detail::Sum* cur = nullptr;  // tets of one ref come in runs
         int32_t cur_ref = 0;
         for (int64_t t = b; t < e; ++t) {
           const int32_t r = m.tet_ref[t];
           if (!cur || r != cur_ref) {
             cur = &a[r];
             cur_ref = r;
           }
           cur->add(tet_volume(m, static_cast<int32_t>(t)));
         }
         return a;
       }))
    for (const auto& [r, sc] : part) acc[r].add(sc);
  std::vector<std::pair<int32_t, double>> out;
  for (auto& [r, sc] : acc) out.emplace_back(r, sc.value());
  return out;
}

}  // namespace tetopt
