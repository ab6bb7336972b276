// Untangling inverted and flat tets by max-min volume ascent (see untangle.hpp).
#include "tetopt/untangle.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "tetopt/invariants.hpp"
#include "tetopt/predicates.hpp"
#include "tetopt/quality.hpp"

namespace tetopt {

const char* to_string(UntangleReason r) {
  switch (r) {
    case UntangleReason::AllConstrained: return "all four vertices constrained";
    case UntangleReason::NoPosition: return "no position found";
  }
  return "?";
}

namespace {

struct V3 {
  double x = 0, y = 0, z = 0;
};
V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
V3 operator*(double s, V3 a) { return {s * a.x, s * a.y, s * a.z}; }
double dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
V3 cross(V3 a, V3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
V3 load(const double* p) { return {p[0], p[1], p[2]}; }

// Minimum-norm point of the convex hull of g[0..n) (n <= 8): the best point
// over all vertices, edges and triangles of the hull; if it fails the
// optimality test p.(g_i - p) >= 0 for some i, the origin lies inside the
// hull and the answer is 0 (the current point maximises the min).
V3 min_norm_point(const V3* g, int n, double eps) {
  V3 best = g[0];
  double bn = dot(best, best);
  auto consider = [&](V3 p) {
    const double q = dot(p, p);
    if (q < bn) { bn = q; best = p; }
  };
  for (int i = 1; i < n; ++i) consider(g[i]);
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      const V3 e = g[j] - g[i];
      const double ee = dot(e, e);
      if (ee <= 0) continue;
      const double t = -dot(g[i], e) / ee;
      if (t > 0 && t < 1) consider(g[i] + t * e);
    }
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      for (int k = j + 1; k < n; ++k) {
        const V3 e1 = g[j] - g[i], e2 = g[k] - g[i];
        const double a11 = dot(e1, e1), a12 = dot(e1, e2), a22 = dot(e2, e2);
        const double det = a11 * a22 - a12 * a12;
        if (!(det > 1e-14 * a11 * a22)) continue;
        const double r1 = -dot(g[i], e1), r2 = -dot(g[i], e2);
        const double u = (r1 * a22 - r2 * a12) / det, w = (a11 * r2 - a12 * r1) / det;
        if (u > 0 && w > 0 && u + w < 1) consider(g[i] + u * e1 + w * e2);
      }
  for (int i = 0; i < n; ++i)
    if (dot(best, g[i] - best) < -eps * (bn + dot(g[i], g[i]))) return V3{};
  return best;
}

class Solver {
 public:
  Solver(TetMesh& m, const UntangleOptions& o) : m_(m), o_(o) {}

  // Tries to move free vertex v; true when a move was committed.
  bool solve(int32_t v) {
    if (m_.vert_constrained[v]) return false;
    const int32_t* b = m_.star_begin(v);
    const int32_t* e = m_.star_end(v);
    const int n = static_cast<int>(e - b);
    if (n == 0) return false;
    g_.resize(n);
    f0_.resize(n);
    pos0_.resize(n);
    const V3 x0 = load(m_.point(v));
    double len = 0;
    int nonpos0 = 0;
    for (int i = 0; i < n; ++i) {
      const int32_t t = b[i];
      const int32_t* tv = m_.tet(t);
      int k = 0;
      while (tv[k] != v) ++k;
      const V3 a = load(m_.point(tv[kFaceVertex[k][0]]));
      const V3 bb = load(m_.point(tv[kFaceVertex[k][1]]));
      const V3 c = load(m_.point(tv[kFaceVertex[k][2]]));
      g_[i] = (-1.0 / 6.0) * cross(bb - a, c - a);
      f0_[i] = dot(g_[i], x0 - a);
      len += std::sqrt(dot(a - x0, a - x0)) + std::sqrt(dot(bb - a, bb - a));
      pos0_[i] = orient3d(m_.point(tv[0]), m_.point(tv[1]), m_.point(tv[2]), m_.point(tv[3])) == Sign::Positive;
      nonpos0 += !pos0_[i];
    }
    len /= 2.0 * n;
    if (!(len > 0) || !std::isfinite(len)) return false;
    const double vol_tol = 1e-12 * len * len * len;
    const double min0 = *std::min_element(f0_.begin(), f0_.end());

    // Steepest ascent of min_i f_i(d), f_i(d) = f0_i + g_i . d, d = x - x0.
    V3 d{};
    f_ = f0_;
    for (int step = 0; step < o_.max_steps; ++step) {
      order_.resize(n);
      for (int i = 0; i < n; ++i) order_[i] = i;
      std::sort(order_.begin(), order_.end(), [&](int i, int j) { return f_[i] < f_[j] || (f_[i] == f_[j] && i < j); });
      const double fmin = f_[order_[0]];
      const double spread = f_[order_[n - 1]] - fmin;
      const double act_tol = std::max(vol_tol, 1e-6 * spread);
      V3 act[8];
      int na = 0;
      for (int i = 0; i < n && na < 8 && f_[order_[i]] <= fmin + act_tol; ++i) act[na++] = g_[order_[i]];
      const V3 dir = min_norm_point(act, na, 1e-9);
      const double dn = dot(dir, dir);
      if (!(dn > 1e-24 * len * len * len * len)) break;
      // Exact maximum of phi(s) = min_i (f_i + s a_i) over s >= 0 by
      // walking the lower envelope from the lowest line at s = 0.
      slope_.resize(n);
      for (int i = 0; i < n; ++i) slope_[i] = dot(g_[i], dir);
      const double s_cap = 10.0 * len / std::sqrt(dn);
      int cur = order_[0];
      for (int i = 0; i < n; ++i)
        if (f_[i] <= fmin + act_tol && slope_[i] < slope_[cur]) cur = i;
      double s = 0;
      for (int guard = 0; guard < 2 * n + 2 && slope_[cur] > 0; ++guard) {
        double next = INFINITY;
        int nj = -1;
        for (int j = 0; j < n; ++j) {
          if (j == cur || !(slope_[j] < slope_[cur])) continue;
          const double gap = (f_[j] + s * slope_[j]) - (f_[cur] + s * slope_[cur]);
          const double sj = s + std::max(0.0, gap) / (slope_[cur] - slope_[j]);
          if (sj < next || (nj >= 0 && sj == next && slope_[j] < slope_[nj])) { next = sj; nj = j; }
        }
        if (nj < 0 || next >= s_cap) { s = std::min(s_cap, nj < 0 ? s_cap : next); break; }
        s = next;
        cur = nj;
      }
      if (!(s > 0)) break;
      const V3 dd = s * dir;
      double newmin = INFINITY;
      for (int i = 0; i < n; ++i) newmin = std::min(newmin, f_[i] + dot(g_[i], dd));
      if (!(newmin > fmin)) break;
      d = d + dd;
      for (int i = 0; i < n; ++i) f_[i] = f0_[i] + dot(g_[i], d);
      if (newmin - fmin <= 1e-9 * std::max(std::fabs(fmin), vol_tol)) break;
    }

    // Commit with exact orientation, halving the step when refused.
    double* p = m_.point(v);
    for (int h = 0; h <= 12; ++h) {
      const double scale = std::ldexp(1.0, -h);
      const V3 x = x0 + scale * d;
      if (x.x == x0.x && x.y == x0.y && x.z == x0.z) break;
      p[0] = x.x; p[1] = x.y; p[2] = x.z;
      int nonpos = 0;
      bool ok = true;
      double fmin = INFINITY;
      for (int i = 0; i < n && ok; ++i) {
        const int32_t* tv = m_.tet(b[i]);
        const bool pos = orient3d(m_.point(tv[0]), m_.point(tv[1]), m_.point(tv[2]), m_.point(tv[3])) == Sign::Positive;
        if (pos0_[i] && !pos) ok = false;
        nonpos += !pos;
        fmin = std::min(fmin, tet_signed_volume(m_.point(tv[0]), m_.point(tv[1]), m_.point(tv[2]), m_.point(tv[3])));
      }
      if (ok && (nonpos < nonpos0 || (nonpos == nonpos0 && fmin > min0 + vol_tol))) return true;
    }
    p[0] = x0.x; p[1] = x0.y; p[2] = x0.z;
    return false;
  }

 private:
  TetMesh& m_;
  const UntangleOptions& o_;
  std::vector<V3> g_;
  std::vector<double> f0_, f_, slope_;
  std::vector<int> order_;
  std::vector<char> pos0_;
};

std::string id_list(const std::vector<UntangleRemaining>& r) {
  std::string s;
  for (size_t i = 0; i < r.size() && i < 20; ++i) {
    if (i) s += ' ';  // (appending "" + to_string trips GCC 12's -Wrestrict false positive)
    s += std::to_string(r[i].tet + 1);
  }
  if (r.size() > 20) s += " ...";
  return s;
}

}  // namespace

UntangleStats untangle(TetMesh& m, const LogFn& log) { return untangle(m, UntangleOptions{}, log); }

UntangleStats untangle(TetMesh& m, const UntangleOptions& o, const LogFn& log) {
  const auto t0 = std::chrono::steady_clock::now();
  UntangleStats st;
  if (m.adj.size() != m.tets.size() || m.vert_constrained.size() != static_cast<size_t>(m.nv())) {
    st.status = Status::error(ErrorCode::Invariant, "untangle: topology not built");
    return st;
  }
  ensure_vertex_tets(m);  // absent after topology passes run without rebuild_stars
  std::vector<int32_t> bad = nonpositive_tets(m);
  st.nonpositive_before = static_cast<int64_t>(bad.size());
  Solver solver(m, o);
  std::vector<int32_t> verts;
  while (!bad.empty() && st.passes < o.passes) {
    ++st.passes;
    verts.clear();
    for (int32_t t : bad)
      for (int k = 0; k < 4; ++k)
        if (!m.vert_constrained[m.tet(t)[k]]) verts.push_back(m.tet(t)[k]);
    std::sort(verts.begin(), verts.end());
    verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
    int64_t moved = 0;
    for (int32_t v : verts) moved += solver.solve(v);
    st.moves += moved;
    bad = nonpositive_tets(m);
    if (moved == 0) break;
  }
  for (int32_t t : bad) {
    const int32_t* v = m.tet(t);
    const bool all = m.vert_constrained[v[0]] && m.vert_constrained[v[1]] && m.vert_constrained[v[2]] &&
                     m.vert_constrained[v[3]];
    st.remaining.push_back({t, all ? UntangleReason::AllConstrained : UntangleReason::NoPosition});
  }
  st.nonpositive_after = static_cast<int64_t>(bad.size());
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (log) {
    log(LogLevel::Info, "untangle: " + std::to_string(st.nonpositive_before) + " inverted or flat tets, " +
                            std::to_string(st.nonpositive_before - st.nonpositive_after) + " repaired by " +
                            std::to_string(st.moves) + " vertex moves in " + std::to_string(st.passes) + " passes");
    if (!st.remaining.empty()) {
      int64_t all = 0;
      for (const auto& r : st.remaining) all += r.reason == UntangleReason::AllConstrained;
      log(LogLevel::Warning, "untangle: " + std::to_string(st.remaining.size()) +
                                 " inverted or flat tets remain (ids " + id_list(st.remaining) + "): " +
                                 std::to_string(all) + " with all four vertices constrained, " +
                                 std::to_string(static_cast<int64_t>(st.remaining.size()) - all) +
                                 " where no position was found");
    }
  }
  return st;
}

}  // namespace tetopt
