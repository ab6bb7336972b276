// Global relaxation for globally bad meshes (see relax.hpp): a
// density-weighted centroidal (Lloyd-type) Jacobi relaxation of every free
// vertex, validated with the exact orient3d, interleaved with quality flips.
// References: Du, Faber & Gunzburger 1999 (centroidal Voronoi tessellations);
// Chen & Xu 2004 and Alliez, Cohen-Steiner, Yvinec & Desbrun 2005 (optimal
// Delaunay triangulations as mesh smoothing).
#include "tetopt/relax.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <queue>
#include <string>
#include <utility>
#include <vector>

#include "tetopt/conventions.hpp"
#include "tetopt/predicates.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/topo.hpp"

#include "detail/parallel.hpp"

namespace tetopt {
namespace {

using Clock = std::chrono::steady_clock;

double dist(const double* a, const double* b) {
  const double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

// Distance from p to triangle abc (closest point by Voronoi regions of the
// triangle, Ericson, "Real-Time Collision Detection" 2005, §5.1.5).
double point_triangle_distance(const double* p, const double* a, const double* b, const double* c) {
  double ab[3], ac[3], ap[3], q[3];
  for (int k = 0; k < 3; ++k) { ab[k] = b[k] - a[k]; ac[k] = c[k] - a[k]; ap[k] = p[k] - a[k]; }
  auto dot = [](const double* x, const double* y) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; };
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return dist(p, a);
  double bp[3], cp[3];
  for (int k = 0; k < 3; ++k) { bp[k] = p[k] - b[k]; cp[k] = p[k] - c[k]; }
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return dist(p, b);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    for (int k = 0; k < 3; ++k) q[k] = a[k] + v * ab[k];
    return dist(p, q);
  }
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return dist(p, c);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    for (int k = 0; k < 3; ++k) q[k] = a[k] + w * ac[k];
    return dist(p, q);
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    for (int k = 0; k < 3; ++k) q[k] = b[k] + w * (c[k] - b[k]);
    return dist(p, q);
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  for (int k = 0; k < 3; ++k) q[k] = a[k] + ab[k] * v + ac[k] * w;
  return dist(p, q);
}

struct AlphaSummary {
  double worst = 0, mean = 0;
};

AlphaSummary summarize(const TetMesh& m) {
  AlphaSummary s;
  s.worst = std::numeric_limits<double>::infinity();
  double sum = 0;
  for (int32_t t = 0; t < m.nt(); ++t) {
    const double a = tet_alpha(m, t);
    s.worst = std::min(s.worst, a);
    sum += a;
  }
  s.mean = m.nt() > 0 ? sum / m.nt() : 0;
  if (m.nt() == 0) s.worst = 0;
  return s;
}

// Vertex -> vertex adjacency (CSR, each neighbour once) from the vertex->tet CSR.
void vertex_graph(const TetMesh& m, std::vector<int32_t>& off, std::vector<int32_t>& nbr) {
  const int32_t nv = m.nv();
  off.assign(static_cast<size_t>(nv) + 1, 0);
  nbr.clear();
  std::vector<int32_t> mark(static_cast<size_t>(nv), -1);
  for (int32_t v = 0; v < nv; ++v) {
    for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it) {
      const int32_t* q = m.tet(*it);
      for (int i = 0; i < 4; ++i) {
        const int32_t u = q[i];
        if (u == v || mark[u] == v) continue;
        mark[u] = v;
        nbr.push_back(u);
      }
    }
    off[v + 1] = static_cast<int32_t>(nbr.size());
  }
}

// One Jacobi relaxation step (essay steps 2 and 3).  Returns accepted moves
// and adds put-backs to *put_back.
int64_t jacobi_step(TetMesh& m, const std::vector<double>& h, double step, double alpha_floor,
                    std::vector<double>& alpha_old, int64_t* put_back, const Guard* guard) {
  const int32_t nv = m.nv(), nt = m.nt();
  alpha_old.resize(static_cast<size_t>(nt));
  for (int32_t t = 0; t < nt; ++t) alpha_old[t] = tet_alpha(m, t);

  // Targets from the current (old) positions.
  std::vector<double> target(static_cast<size_t>(3) * nv, 0.0);
  std::vector<uint8_t> movable(static_cast<size_t>(nv), 0);
  for (int32_t v = 0; v < nv; ++v) {
    if (m.vert_constrained[v] || m.star_begin(v) == m.star_end(v)) continue;
    double acc[3] = {0, 0, 0}, wsum = 0;
    for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it) {
      const int32_t* q = m.tet(*it);
      const double vol = tet_volume(m, *it);
      if (!(vol > 0)) continue;
      const double ht = 0.25 * (h[q[0]] + h[q[1]] + h[q[2]] + h[q[3]]);
      const double w = vol / (ht * ht * ht);
      for (int k = 0; k < 3; ++k)
        acc[k] += w * 0.25 * (m.point(q[0])[k] + m.point(q[1])[k] + m.point(q[2])[k] + m.point(q[3])[k]);
      wsum += w;
    }
    if (!(wsum > 0)) continue;
    for (int k = 0; k < 3; ++k) target[3 * static_cast<size_t>(v) + k] = acc[k] / wsum;
    movable[v] = 1;
  }

  const std::vector<double> old = m.xyz;
  std::vector<double> frac(static_cast<size_t>(nv), step);
  std::vector<uint8_t> moved(static_cast<size_t>(nv), 0);
  std::vector<uint8_t> tet_mark(static_cast<size_t>(nt), 0);
  std::vector<int32_t> to_check;
  int64_t accepted = 0;

  auto place = [&](int32_t v, double f) {
    for (int k = 0; k < 3; ++k) {
      const size_t i = 3 * static_cast<size_t>(v) + k;
      m.xyz[i] = old[i] + f * (target[i] - old[i]);
    }
  };
  auto restore = [&](int32_t v) {
    for (int k = 0; k < 3; ++k) m.xyz[3 * static_cast<size_t>(v) + k] = old[3 * static_cast<size_t>(v) + k];
    moved[v] = 0;
  };
  auto ok = [&](int32_t t) {
    const int32_t* q = m.tet(t);
    if (orient3d(m.point(q[0]), m.point(q[1]), m.point(q[2]), m.point(q[3])) != Sign::Positive) return false;
    const double a = tet_alpha(m, t);
    if (!(a >= std::min(alpha_old[t], alpha_floor))) return false;
    return !guard || guard->admits(m.point(q[0]), m.point(q[1]), m.point(q[2]), m.point(q[3]));
  };

  // Attempt 0 moves every movable vertex by `step`; attempts 1 and 2 retry
  // the put-back ones with half the previous fraction.
  std::vector<int32_t> trying;
  for (int32_t v = 0; v < nv; ++v)
    if (movable[v]) trying.push_back(v);
  for (int attempt = 0; attempt < 3 && !trying.empty(); ++attempt) {
    to_check.clear();
    for (int32_t v : trying) {
      place(v, frac[v]);
      moved[v] = 1;
      for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it)
        if (!tet_mark[*it]) { tet_mark[*it] = 1; to_check.push_back(*it); }
    }
    std::vector<int32_t> failed_vertices;
    while (!to_check.empty()) {
      std::vector<int32_t> next;
      for (int32_t t : to_check) tet_mark[t] = 0;
      for (int32_t t : to_check) {
        if (ok(t)) continue;
        const int32_t* q = m.tet(t);
        for (int i = 0; i < 4; ++i) {
          const int32_t u = q[i];
          if (!moved[u]) continue;
          restore(u);
          failed_vertices.push_back(u);
          for (const int32_t* it = m.star_begin(u); it != m.star_end(u); ++it)
            if (!tet_mark[*it]) { tet_mark[*it] = 1; next.push_back(*it); }
        }
      }
      to_check.swap(next);
    }
    for (int32_t v : trying) accepted += moved[v];
    // Accepted vertices are now fixed for this step: make their new position
    // the reference so later attempts validate against it.
    for (int32_t v : trying) moved[v] = 0;
    std::sort(failed_vertices.begin(), failed_vertices.end());
    failed_vertices.erase(std::unique(failed_vertices.begin(), failed_vertices.end()), failed_vertices.end());
    *put_back += static_cast<int64_t>(failed_vertices.size());
    for (int32_t v : failed_vertices) frac[v] *= 0.5;
    // Re-snapshot: alpha of every tet in the current configuration is the
    // reference of the next attempt (all are valid now).
    for (int32_t v : failed_vertices)
      for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it) alpha_old[*it] = tet_alpha(m, *it);
    trying.swap(failed_vertices);
  }
  return accepted;
}

}  // namespace

double bad_tet_fraction(const TetMesh& m, int threads) {
  if (m.nt() == 0) return 0;
  const int64_t bad =
      detail::parallel_count(m.nt(), threads, [&](int64_t t) { return tet_alpha(m, static_cast<int32_t>(t)) < 0.1; });
  return static_cast<double>(bad) / m.nt();
}

bool relax_wanted(const TetMesh& m, const RelaxOptions& o, int threads) {
  return bad_tet_fraction(m, threads) >= o.trigger_fraction;
}

std::vector<double> relax_size_field(const TetMesh& m, double gradation) {
  const int32_t nv = m.nv(), nt = m.nt();
  constexpr double kNone = -std::numeric_limits<double>::infinity();
  std::vector<double> h(static_cast<size_t>(nv), kNone);
  std::vector<int32_t> src(static_cast<size_t>(nv), -1);  // source face (index into faces)
  // Constrained faces with their size (mean edge length); each face once
  // (the copy seen from the tet with the smaller id, or the only one).
  std::vector<std::array<int32_t, 3>> faces;
  std::vector<double> face_h;
  for (int32_t t = 0; t < nt; ++t) {
    if (!m.face_mask[t]) continue;
    const int32_t* q = m.tet(t);
    for (int f = 0; f < 4; ++f) {
      if (!(m.face_mask[t] & (1u << f))) continue;
      const int32_t nb = m.adj[4 * static_cast<size_t>(t) + f];
      if (nb >= 0 && nb / 4 < t) continue;
      const std::array<int32_t, 3> tri{q[kFaceVertex[f][0]], q[kFaceVertex[f][1]], q[kFaceVertex[f][2]]};
      faces.push_back(tri);
      face_h.push_back((dist(m.point(tri[0]), m.point(tri[1])) + dist(m.point(tri[1]), m.point(tri[2])) +
                        dist(m.point(tri[2]), m.point(tri[0]))) / 3.0);
    }
  }
  double volume = 0;
  for (int32_t t = 0; t < nt; ++t) volume += std::max(0.0, tet_volume(m, t));
  int64_t n_free = 0;
  for (int32_t v = 0; v < nv; ++v) n_free += !m.vert_constrained[v] && m.star_begin(v) != m.star_end(v);
  const double h_min = n_free > 0 ? std::cbrt(volume / static_cast<double>(n_free)) : 0.0;

  // Multi-source Dijkstra over mesh edges, largest size first, carrying the
  // source face so each value is the exact h_f - g * dist(point, triangle f)
  // of some face f (the usual feature-propagation distance transform).
  std::vector<int32_t> off, nbr;
  vertex_graph(m, off, nbr);
  using Item = std::pair<double, int32_t>;
  std::priority_queue<Item> heap;
  auto offer = [&](int32_t u, int32_t f) {
    const auto& tri = faces[static_cast<size_t>(f)];
    const double cand =
        face_h[static_cast<size_t>(f)] -
        gradation * point_triangle_distance(m.point(u), m.point(tri[0]), m.point(tri[1]), m.point(tri[2]));
    if (cand > h[u] && cand > h_min) {
      h[u] = cand;
      src[u] = f;
      heap.push({cand, u});
    }
  };
  for (size_t f = 0; f < faces.size(); ++f)
    for (int i = 0; i < 3; ++i) offer(faces[f][i], static_cast<int32_t>(f));
  while (!heap.empty()) {
    const auto [hv, v] = heap.top();
    heap.pop();
    if (hv < h[v]) continue;
    for (int32_t k = off[v]; k < off[v + 1]; ++k) offer(nbr[k], src[v]);
  }
  for (int32_t v = 0; v < nv; ++v) {
    if (m.star_begin(v) == m.star_end(v)) h[v] = 0;
    else h[v] = std::max(h[v], h_min);
  }
  return h;
}

RelaxStats relax_pass(TetMesh& m, const RelaxOptions& o, const LogFn& log) {
  const auto t0 = Clock::now();
  RelaxStats st;
  ensure_vertex_tets(m);  // absent after topology passes run without rebuild_stars
  AlphaSummary s = summarize(m);
  st.alpha_worst_before = s.worst;
  st.alpha_mean_before = s.mean;
  std::vector<double> alpha_old;
  double prev_mean = s.mean;
  for (int round = 0; round < o.rounds; ++round) {
    TopoOptions to;
    to.quality_threshold = o.flip_threshold;
    to.passes = 1;
    to.guard = o.guard;
    to.threads = o.threads;
    const TopoStats ts = flip_pass(m, to);
    if (!ts.status) {
      st.status = ts.status;
      break;
    }
    st.flips += ts.applied();
    const std::vector<double> h = relax_size_field(m, o.gradation);
    int64_t moved = 0;
    for (int k = 0; k < o.steps; ++k) moved += jacobi_step(m, h, o.step, o.alpha_floor, alpha_old, &st.put_back, o.guard);
    st.moves += moved;
    st.rounds = round + 1;
    s = summarize(m);
    if (log) {
      char buf[200];
      std::snprintf(buf, sizeof buf, "relax round %d: %lld flips, %lld moves, worst alpha %.4f, mean %.4f",
                    round + 1, static_cast<long long>(ts.applied()), static_cast<long long>(moved), s.worst,
                    s.mean);
      log(LogLevel::Progress, buf);
    }
    if (round >= 2 && s.mean < prev_mean + o.min_gain) break;
    prev_mean = std::max(prev_mean, s.mean);
  }
  st.alpha_worst_after = s.worst;
  st.alpha_mean_after = s.mean;
  st.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return st;
}

}  // namespace tetopt
